#include "swarmloc/world/murp_calibration.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>

#include "swarmloc/config/scenario.hpp"

namespace swarmloc::world {
namespace {

using estimators::uwb::RangeBias;

constexpr int kOffsets = kMurpVehicles * kMurpAntennas;
constexpr int kParameters = kOffsets + RangeBias::kFeatures;
using ParameterVector = Eigen::Matrix<double, kParameters, 1>;
using NormalMatrix = Eigen::Matrix<double, kParameters, kParameters>;

/// One valid range: which offsets it carries, its geometry features, measured − geometric range, and the
/// spread of its readings (0 where the file gives none: a window of one reading).
struct RangeSample {
  int base_offset = 0;    ///< index of the base antenna's offset in the parameter vector
  int target_offset = 0;  ///< the target antenna's
  RangeBias::Features features;
  double residual_m = 0.0;
  double spread_m = 0.0;
};

double sample_median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

/// The Gaussian-consistent std of zero-centred residuals from their absolute values: 1.4826·median.
double robust_std(std::vector<double> absolute_values) {
  return 1.4826 * sample_median(std::move(absolute_values));
}

void collect_window(const MurpPairLog& log, const MurpWindow& window, std::vector<RangeSample>& samples) {
  for (int i = 0; i < kMurpAntennas; ++i) {
    for (int j = 0; j < kMurpAntennas; ++j) {
      const double range = window.ranges_m(i, j);
      if (!std::isfinite(range)) continue;
      const auto geometry = murp_pair_geometry(window.base, window.target, i, j);
      const double spread = window.range_std_m(i, j);
      samples.push_back({(log.base - 1) * kMurpAntennas + i, (log.target - 1) * kMurpAntennas + j,
                         geometry.features, range - geometry.range_m, std::isfinite(spread) ? spread : 0.0});
    }
  }
}

std::vector<RangeSample> collect_samples(const std::vector<MurpTrial>& trials) {
  std::vector<RangeSample> samples;
  for (const auto& trial : trials) {
    for (const auto& log : trial.pairs) {
      for (const auto& window : log.windows) collect_window(log, window, samples);
    }
  }
  return samples;
}

double predicted_bias(const RangeSample& s, const ParameterVector& parameters) {
  return parameters(s.base_offset) + parameters(s.target_offset) +
         parameters.tail<RangeBias::kFeatures>().dot(s.features);
}

/// Adds weight·x·xᵀ and weight·x·y of one range to the normal equations; x has two ones (its antennas'
/// offsets) and the geometry features, so only those entries are touched.
void accumulate(const RangeSample& s, double weight, NormalMatrix& normal, ParameterVector& gradient) {
  std::array<int, 2 + RangeBias::kFeatures> index{};
  std::array<double, 2 + RangeBias::kFeatures> value{};
  index[0] = s.base_offset;
  index[1] = s.target_offset;
  value[0] = value[1] = 1.0;
  for (std::size_t f = 0; f < RangeBias::kFeatures; ++f) {
    index[2 + f] = kOffsets + static_cast<int>(f);
    value[2 + f] = s.features(static_cast<Eigen::Index>(f));
  }
  for (std::size_t a = 0; a < index.size(); ++a) {
    gradient(index[a]) += weight * value[a] * s.residual_m;
    for (std::size_t b = 0; b < index.size(); ++b) normal(index[a], index[b]) += weight * value[a] * value[b];
  }
}

std::vector<double> absolute_errors(const std::vector<RangeSample>& samples,
                                    const ParameterVector& parameters) {
  std::vector<double> errors;
  errors.reserve(samples.size());
  for (const auto& s : samples) errors.push_back(std::abs(s.residual_m - predicted_bias(s, parameters)));
  return errors;
}

/// Iteratively reweighted ridge least squares with Huber weights (docs/real-data.md "MURP range
/// calibration"): the scale is re-estimated from the residuals before each solve, starting from those of
/// no bias at all.
ParameterVector fit_bias(const std::vector<RangeSample>& samples) {
  ParameterVector parameters = ParameterVector::Zero();
  for (int iteration = 0; iteration < kMurpFitIterations; ++iteration) {
    const auto errors = absolute_errors(samples, parameters);
    const double threshold = kMurpHuberThreshold * robust_std(errors);
    NormalMatrix normal = kMurpRidge * NormalMatrix::Identity();
    ParameterVector gradient = ParameterVector::Zero();
    for (std::size_t k = 0; k < samples.size(); ++k) {
      const double weight = errors[k] <= threshold ? 1.0 : threshold / errors[k];
      accumulate(samples[k], weight, normal, gradient);
    }
    parameters = normal.ldlt().solve(gradient);
  }
  return parameters;
}

std::vector<MurpSpreadBin> spread_bins(const std::vector<RangeSample>& samples,
                                       const std::vector<double>& errors) {
  std::vector<MurpSpreadBin> bins;
  for (std::size_t b = 0; b < kMurpSpreadEdges.size(); ++b) {
    MurpSpreadBin bin;
    bin.from_m = kMurpSpreadEdges[b];
    bin.to_m =
        b + 1 < kMurpSpreadEdges.size() ? kMurpSpreadEdges[b + 1] : std::numeric_limits<double>::infinity();
    std::vector<double> in_bin;
    std::vector<double> spreads;
    for (std::size_t k = 0; k < samples.size(); ++k) {
      if (samples[k].spread_m < bin.from_m || samples[k].spread_m >= bin.to_m) continue;
      in_bin.push_back(errors[k]);
      spreads.push_back(samples[k].spread_m);
    }
    bin.ranges = in_bin.size();
    bin.median_spread_m = sample_median(std::move(spreads));
    bin.robust_std_m = robust_std(std::move(in_bin));
    bins.push_back(bin);
  }
  return bins;
}

/// The count-weighted squared log misfit of the bins' robust stds to the model with gain κ at their median
/// spread.
double spread_misfit(const std::vector<MurpSpreadBin>& bins, double range_std_m, double gain) {
  double misfit = 0.0;
  for (const auto& bin : bins) {
    if (bin.ranges == 0 || !(bin.robust_std_m > 0.0)) continue;
    const double spread_sq = bin.median_spread_m * bin.median_spread_m;
    const double log_ratio = std::log(bin.robust_std_m / std::hypot(range_std_m, gain * spread_sq));
    misfit += static_cast<double>(bin.ranges) * log_ratio * log_ratio;
  }
  return misfit;
}

/// κ of σ(spread) = √(σ0² + (κ·spread²)²), σ0 fixed: the least count-weighted squared log misfit over the
/// bins (spread_misfit), on a grid of κ evenly spaced in log from 1e-3 to 1e3 and κ = 0. In logs each
/// bin's misfit counts as a ratio: the bins near the floor and the few ranges of the widest spreads both
/// weigh as their counts say. A plain Gaussian likelihood over the ranges would let the gross errors of
/// the widest spreads set κ.
double fit_spread_gain(const std::vector<MurpSpreadBin>& bins, double range_std_m) {
  constexpr int kSteps = 3000;
  double best_gain = 0.0;
  double best_misfit = spread_misfit(bins, range_std_m, 0.0);
  for (int k = 0; k <= kSteps; ++k) {
    const double gain = std::pow(10.0, -3.0 + 6.0 * k / kSteps);
    const double misfit = spread_misfit(bins, range_std_m, gain);
    if (misfit < best_misfit) {
      best_misfit = misfit;
      best_gain = gain;
    }
  }
  return best_gain;
}

std::vector<std::string> trial_names(const std::vector<MurpTrial>& trials) {
  std::vector<std::string> names;
  names.reserve(trials.size());
  for (const auto& trial : trials) names.push_back(trial.name);
  return names;
}

void check_vehicle(int vehicle, const char* role) {
  if (vehicle < 1 || vehicle > kMurpVehicles) {
    throw std::invalid_argument(std::string("murp_range_model: ") + role + " vehicle " +
                                std::to_string(vehicle) + " is outside 1-" + std::to_string(kMurpVehicles));
  }
}

}  // namespace

std::vector<Vec3> murp_lever_arms() {
  return estimators::uwb::ring_lever_arms(kMurpAntennas, 0.32, std::numbers::pi / 6.0);
}

MurpPairGeometry murp_pair_geometry(const MurpPose& base, const MurpPose& target, int base_antenna,
                                    int target_antenna) {
  static const auto arms = murp_lever_arms();
  const Mat3 base_rotation = murp_rotation(base);
  const Mat3 target_rotation = murp_rotation(target);
  const Vec3& base_arm = arms.at(static_cast<std::size_t>(base_antenna));
  const Vec3& target_arm = arms.at(static_cast<std::size_t>(target_antenna));
  const Vec3 line =
      target.position_m + target_rotation * target_arm - base.position_m - base_rotation * base_arm;
  MurpPairGeometry out;
  out.range_m = line.norm();
  const Vec3 u = line / out.range_m;
  // The filter's features in the base's level frame are dot products and a vertical component, which the
  // world frame (the level frame turned by the base's yaw) leaves unchanged.
  out.features = estimators::uwb::geometry_features(u.z(), (base_rotation * base_arm.normalized()).dot(u),
                                                    -(target_rotation * target_arm.normalized()).dot(u));
  return out;
}

MurpRangeCalibration calibrate_murp_ranges(const std::vector<MurpTrial>& trials) {
  const auto samples = collect_samples(trials);
  if (samples.size() < kMurpMinCalibrationRanges) {
    throw config::ScenarioError("calibrate --murp: " + std::to_string(samples.size()) +
                                " valid ranges in the trials, fewer than the " +
                                std::to_string(kMurpMinCalibrationRanges) + " a fit needs");
  }
  const ParameterVector parameters = fit_bias(samples);
  const auto errors = absolute_errors(samples, parameters);
  MurpRangeCalibration out;
  for (int v = 0; v < kMurpVehicles; ++v) {
    for (int i = 0; i < kMurpAntennas; ++i) {
      out.antenna_offsets_m[static_cast<std::size_t>(v)][static_cast<std::size_t>(i)] =
          parameters(v * kMurpAntennas + i);
    }
  }
  out.coefficients_m = parameters.tail<RangeBias::kFeatures>();
  out.range_std_m = robust_std(errors);
  out.ranges_used = samples.size();
  const auto outliers = std::count_if(errors.begin(), errors.end(),
                                      [&](double e) { return e > kMurpOutlierSigmas * out.range_std_m; });
  out.outlier_fraction = static_cast<double>(outliers) / static_cast<double>(samples.size());
  out.spread_bins = spread_bins(samples, errors);
  out.spread_noise_gain = fit_spread_gain(out.spread_bins, out.range_std_m);
  out.trials = trial_names(trials);
  return out;
}

estimators::uwb::RangeCalibration murp_range_calibration(const MurpRangeCalibration& calibration) {
  estimators::uwb::RangeCalibration out;
  for (int v = 0; v < kMurpVehicles; ++v) {
    const auto& offsets = calibration.antenna_offsets_m[static_cast<std::size_t>(v)];
    out.vehicles[v + 1] = {murp_lever_arms(), Eigen::Map<const VecX>(offsets.data(), kMurpAntennas)};
  }
  out.coefficients_m = calibration.coefficients_m;
  out.range_std_m = calibration.range_std_m;
  out.spread_noise_gain = calibration.spread_noise_gain;
  out.fitted_on = calibration.trials;
  return out;
}

estimators::uwb::RelativePoseParams murp_range_model(const MurpRangeCalibration* calibration, int base,
                                                     int target) {
  check_vehicle(base, "base");
  check_vehicle(target, "target");
  if (base == target) throw std::invalid_argument("murp_range_model: base and target are the same vehicle");
  estimators::uwb::RelativePoseParams params;
  if (calibration != nullptr) {
    params = estimators::uwb::range_model(murp_range_calibration(*calibration), base, target);
  } else {
    params.my_lever_arms_m = murp_lever_arms();
    params.peer_lever_arms_m = murp_lever_arms();
  }
  params.heading_walk_radps = 0.2;
  params.position_walk_mps = 3.0;
  return params;
}

}  // namespace swarmloc::world
