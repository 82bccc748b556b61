#include "swarmloc/world/mrclam_calibration.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <numbers>
#include <tuple>

#include "mrclam_odometry_calibration.hpp"
#include "swarmloc/models/measurement_models.hpp"

namespace swarmloc::world {
namespace {

using detail::calibrate_odometry;
using detail::odometry_residuals;
using detail::WindowResiduals;
using detail::within_trim;

using GroundtruthPose = MrclamDataset::TimedPose;
using Pair = std::array<double, 2>;

double median_of(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

struct ChannelEstimate {
  double centre = 0.0;
  double scale = 0.0;
};

/// Median and 1.4826·MAD (the Gaussian-consistent MAD) of one channel; the plain std if the MAD is 0.
ChannelEstimate median_mad(const std::vector<Pair>& residuals, std::size_t channel) {
  std::vector<double> values;
  values.reserve(residuals.size());
  for (const auto& r : residuals) values.push_back(r[channel]);
  const double centre = median_of(values);
  for (auto& v : values) v = std::abs(v - centre);
  double scale = 1.4826 * median_of(values);
  if (!(scale > 0.0)) {
    double sum = 0.0;
    for (const auto& r : residuals) sum += (r[channel] - centre) * (r[channel] - centre);
    scale = std::sqrt(sum / static_cast<double>(residuals.size()));
  }
  return {centre, scale};
}

std::vector<bool> inlier_mask(const std::vector<Pair>& residuals, const std::array<ChannelEstimate, 2>& est,
                              PairTrim trim) {
  std::vector<bool> mask(residuals.size());
  for (std::size_t i = 0; i < residuals.size(); ++i) {
    mask[i] = trim.inside(PairTrim::standardized(residuals[i][0] - est[0].centre, est[0].scale),
                          PairTrim::standardized(residuals[i][1] - est[1].centre, est[1].scale));
  }
  return mask;
}

/// Mean and truncation-corrected std of the masked residuals, per channel.
std::array<ChannelEstimate, 2> inlier_moments(const std::vector<Pair>& residuals,
                                              const std::vector<bool>& mask, double variance_factor) {
  std::array<ChannelEstimate, 2> est{};
  std::size_t n = 0;
  for (std::size_t i = 0; i < residuals.size(); ++i) {
    if (!mask[i]) continue;
    ++n;
    for (std::size_t c = 0; c < 2; ++c) est[c].centre += residuals[i][c];
  }
  if (n < 2) return est;
  for (auto& e : est) e.centre /= static_cast<double>(n);
  for (std::size_t i = 0; i < residuals.size(); ++i) {
    if (!mask[i]) continue;
    for (std::size_t c = 0; c < 2; ++c) {
      const double d = residuals[i][c] - est[c].centre;
      est[c].scale += d * d;
    }
  }
  for (auto& e : est) e.scale = std::sqrt(e.scale / static_cast<double>(n - 1) / variance_factor);
  return est;
}

/// Relative bearing of `target` from `pose` (robot frame), wrapped.
double bearing_from(const GroundtruthPose& pose, const Vec2& target) {
  const Vec2 d = target - pose.position_m;
  return models::wrap_angle(std::atan2(d.y(), d.x()) - pose.heading_rad);
}

/// One sighting's residual, its true range (for the range bins) and who saw what when (for the pairs of
/// consecutive sightings).
struct SightingResidual {
  Pair residual{};  ///< range (m), bearing (rad)
  double true_range_m = 0.0;
  double time_s = 0.0;
  std::size_t robot = 0;
  int subject = 0;
  Vec2 target_m = Vec2::Zero();  ///< where the subject was (a landmark's surveyed position)
  double measured_bearing_rad = 0.0;
};

struct SightingResiduals {
  std::vector<SightingResidual> landmarks;
  std::vector<SightingResidual> robots;
  std::size_t landmark_gaps = 0;
  std::size_t robot_gaps = 0;
};

SightingResiduals sighting_residuals(const MrclamDataset& data, std::size_t robot, double max_gap_s) {
  SightingResiduals out;
  const auto& self = data.robots[robot];
  for (const auto& m : self.measurements) {
    const bool landmark = m.subject > kMrclamRobots;
    auto& gaps = landmark ? out.landmark_gaps : out.robot_gaps;
    const auto pose = groundtruth_at(self.groundtruth, m.time_s, max_gap_s);
    std::optional<Vec2> target;
    if (landmark) {
      const auto found = data.landmarks.find(m.subject);
      if (found == data.landmarks.end()) continue;  // the loader already drops these
      target = found->second.position_m;
    } else {
      const auto seen = groundtruth_at(data.robots.at(static_cast<std::size_t>(m.subject - 1)).groundtruth,
                                       m.time_s, max_gap_s);
      if (seen) target = seen->position_m;
    }
    if (!pose || !target) {
      ++gaps;
      continue;
    }
    const double true_range = (*target - pose->position_m).norm();
    const SightingResidual r{
        {m.range_m - true_range, models::wrap_angle(m.bearing_rad - bearing_from(*pose, *target))},
        true_range,
        m.time_s,
        robot,
        m.subject,
        *target,
        m.bearing_rad};
    (landmark ? out.landmarks : out.robots).push_back(r);
  }
  return out;
}

std::vector<RangeBin> range_bins(const std::vector<SightingResidual>& sightings, const RobustStats& range,
                                 const RobustStats& bearing, PairTrim trim) {
  std::vector<std::vector<double>> by_metre;
  for (const auto& s : sightings) {
    if (!within_trim(s.residual, range, bearing, trim)) continue;
    const auto bin = static_cast<std::size_t>(std::floor(s.true_range_m));
    if (bin >= by_metre.size()) by_metre.resize(bin + 1);
    by_metre[bin].push_back(s.residual[0]);
  }
  std::vector<RangeBin> bins;
  for (std::size_t b = 0; b < by_metre.size(); ++b) {
    const auto& values = by_metre[b];
    if (values.size() < kMinBinSamples) continue;
    double mean = 0.0;
    for (double v : values) mean += v;
    mean /= static_cast<double>(values.size());
    double sum = 0.0;
    for (double v : values) sum += (v - mean) * (v - mean);
    bins.push_back({static_cast<double>(b), static_cast<double>(b + 1), values.size(), mean,
                    std::sqrt(sum / static_cast<double>(values.size() - 1))});
  }
  return bins;
}

/// Count-weighted least squares std = a + b·(bin centre); a flat line through one bin.
std::pair<double, double> fit_std_line(const std::vector<RangeBin>& bins) {
  double w = 0.0, wx = 0.0, wy = 0.0, wxx = 0.0, wxy = 0.0;
  for (const auto& bin : bins) {
    const double n = static_cast<double>(bin.samples);
    const double x = 0.5 * (bin.from_m + bin.to_m);
    w += n, wx += n * x, wy += n * bin.std_m, wxx += n * x * x, wxy += n * x * bin.std_m;
  }
  if (w == 0.0) return {0.0, 0.0};
  const double denominator = w * wxx - wx * wx;
  if (bins.size() < 2 || denominator <= 0.0) return {wy / w, 0.0};
  const double slope = (w * wxy - wx * wy) / denominator;
  return {(wy - slope * wx) / w, slope};
}

// ---- Correlation of consecutive sightings (docs/real-data.md, "Correlated sighting errors") ----

/// Gap bins: fine where the correlation falls fast, coarse out to kMaxCorrelationGapS.
constexpr std::array<double, 9> kCorrelationGapEdgesS{
    0.0, 0.25, 0.5, 1.0, 2.0, 5.0, 10.0, 30.0, kMaxCorrelationGapS};
/// τ candidates: a log grid over 0.1–300 s, about 3.4 % apart (far finer than the fit's uncertainty).
constexpr double kMinCorrelationTimeS = 0.1;
constexpr double kMaxCorrelationTimeS = 300.0;
constexpr int kCorrelationTimeSteps = 240;

/// Two consecutive inlier sightings of one subject by one robot, residuals less their robot's mean.
struct ConsecutivePair {
  double gap_s = 0.0;
  Pair earlier{};
  Pair later{};
};

/// Inlier mean of each robot's residuals: a robot's constant bias would otherwise read as a correlation
/// that never decays.
std::vector<Pair> per_robot_means(const std::vector<const SightingResidual*>& inliers) {
  std::vector<Pair> sums;
  std::vector<double> counts;
  for (const auto* s : inliers) {
    if (s->robot >= sums.size()) {
      sums.resize(s->robot + 1, Pair{});
      counts.resize(s->robot + 1, 0.0);
    }
    sums[s->robot][0] += s->residual[0];
    sums[s->robot][1] += s->residual[1];
    counts[s->robot] += 1.0;
  }
  for (std::size_t r = 0; r < sums.size(); ++r) {
    if (counts[r] > 0.0) sums[r] = {sums[r][0] / counts[r], sums[r][1] / counts[r]};
  }
  return sums;
}

/// The sightings within the outlier trim, and each robot's mean over them.
struct TrimmedSightings {
  std::vector<const SightingResidual*> inliers;
  std::vector<Pair> robot_means;

  TrimmedSightings(const std::vector<SightingResidual>& sightings, const RobustStats& range,
                   const RobustStats& bearing, PairTrim trim) {
    for (const auto& s : sightings) {
      if (within_trim(s.residual, range, bearing, trim)) inliers.push_back(&s);
    }
    robot_means = per_robot_means(inliers);
  }
  /// A sighting's residual less its robot's mean.
  [[nodiscard]] Pair centred(const SightingResidual& s) const {
    return {s.residual[0] - robot_means[s.robot][0], s.residual[1] - robot_means[s.robot][1]};
  }
};

std::vector<ConsecutivePair> consecutive_pairs(const std::vector<SightingResidual>& sightings,
                                               const RobustStats& range, const RobustStats& bearing,
                                               PairTrim trim) {
  TrimmedSightings trimmed(sightings, range, bearing, trim);
  auto& inliers = trimmed.inliers;
  std::stable_sort(inliers.begin(), inliers.end(), [](const auto* a, const auto* b) {
    return std::tie(a->robot, a->subject, a->time_s) < std::tie(b->robot, b->subject, b->time_s);
  });
  std::vector<ConsecutivePair> pairs;
  for (std::size_t i = 1; i < inliers.size(); ++i) {
    const auto& earlier = *inliers[i - 1];
    const auto& later = *inliers[i];
    if (earlier.robot != later.robot || earlier.subject != later.subject) continue;
    const double gap = later.time_s - earlier.time_s;
    if (gap > kMaxCorrelationGapS) continue;
    pairs.push_back({gap, trimmed.centred(earlier), trimmed.centred(later)});
  }
  return pairs;
}

/// Pearson correlation of the earlier against the later residual of one channel; 0 when either is constant.
double pair_correlation(const std::vector<ConsecutivePair>& pairs, std::size_t channel) {
  if (pairs.size() < 2) return 0.0;
  double mean_earlier = 0.0, mean_later = 0.0;
  for (const auto& p : pairs) mean_earlier += p.earlier[channel], mean_later += p.later[channel];
  mean_earlier /= static_cast<double>(pairs.size());
  mean_later /= static_cast<double>(pairs.size());
  double cross = 0.0, earlier_sq = 0.0, later_sq = 0.0;
  for (const auto& p : pairs) {
    const double a = p.earlier[channel] - mean_earlier;
    const double b = p.later[channel] - mean_later;
    cross += a * b, earlier_sq += a * a, later_sq += b * b;
  }
  return earlier_sq > 0.0 && later_sq > 0.0 ? cross / std::sqrt(earlier_sq * later_sq) : 0.0;
}

/// Every pair of inlier sightings of two different subjects by one robot in one camera frame, binned by how
/// far apart the subjects are; residuals less their robot's mean.
std::vector<SeparationBin> same_frame_bins(const std::vector<SightingResidual>& sightings,
                                           const RobustStats& range, const RobustStats& bearing,
                                           PairTrim trim) {
  TrimmedSightings trimmed(sightings, range, bearing, trim);
  auto& inliers = trimmed.inliers;
  std::stable_sort(inliers.begin(), inliers.end(), [](const auto* a, const auto* b) {
    return std::tie(a->robot, a->time_s) < std::tie(b->robot, b->time_s);
  });
  constexpr std::array<double, 7> kEdgesM{0.0, 0.25, 0.5, 1.0, 2.0, 4.0, 1e9};
  std::array<std::vector<ConsecutivePair>, kEdgesM.size() - 1> pairs;
  for (std::size_t i = 1; i < inliers.size(); ++i) {
    const auto& later = *inliers[i];
    for (std::size_t k = i; k-- > 0;) {
      const auto& earlier = *inliers[k];
      if (earlier.robot != later.robot || later.time_s - earlier.time_s > kSameFrameS) break;
      if (earlier.subject == later.subject) continue;
      const double separation = (earlier.target_m - later.target_m).norm();
      const auto bin = std::upper_bound(kEdgesM.begin(), kEdgesM.end(), separation) - kEdgesM.begin() - 1;
      if (bin >= 0 && static_cast<std::size_t>(bin) < pairs.size()) {
        pairs[static_cast<std::size_t>(bin)].push_back(
            {later.time_s - earlier.time_s, trimmed.centred(earlier), trimmed.centred(later)});
      }
    }
  }
  std::vector<SeparationBin> bins;
  for (std::size_t b = 0; b < pairs.size(); ++b) {
    bins.push_back({kEdgesM[b], kEdgesM[b + 1], pairs[b].size(), pair_correlation(pairs[b], 0),
                    pair_correlation(pairs[b], 1)});
  }
  return bins;
}

double cluster_radius(const std::vector<SeparationBin>& bins) {
  double radius = 0.0;
  for (const auto& bin : bins) {
    if (bin.pairs < kMinBinSamples) continue;
    if (bin.range_rho < kClusterMinRho) break;
    radius = bin.to_m;
  }
  return radius;
}

std::vector<CorrelationBin> correlation_bins(const std::vector<ConsecutivePair>& pairs) {
  std::vector<CorrelationBin> bins;
  for (std::size_t b = 0; b + 1 < kCorrelationGapEdgesS.size(); ++b) {
    const double from = kCorrelationGapEdgesS[b];
    const double to = kCorrelationGapEdgesS[b + 1];
    std::vector<ConsecutivePair> in_bin;
    // The last bin is closed: a gap of exactly kMaxCorrelationGapS was paired, so it is counted.
    const bool last = b + 2 == kCorrelationGapEdgesS.size();
    std::copy_if(pairs.begin(), pairs.end(), std::back_inserter(in_bin),
                 [&](const auto& p) { return p.gap_s >= from && (p.gap_s < to || (last && p.gap_s == to)); });
    double gap_sum = 0.0;
    for (const auto& p : in_bin) gap_sum += p.gap_s;
    const double mean_gap = in_bin.empty() ? 0.5 * (from + to) : gap_sum / static_cast<double>(in_bin.size());
    bins.push_back(
        {from, to, in_bin.size(), mean_gap, pair_correlation(in_bin, 0), pair_correlation(in_bin, 1)});
  }
  return bins;
}

double bin_rho(const CorrelationBin& bin, std::size_t channel) {
  return channel == 0 ? bin.range_rho : bin.bearing_rho;
}

/// c of one channel at a given τ, and its pair-weighted squared misfit over the bins.
struct FractionFit {
  double fraction = 0.0;
  double misfit = 0.0;
};

/// Weighted least squares of ρ_b ≈ c·exp(−Δt_b/τ): linear in c, so closed form, then clamped.
FractionFit fit_fraction(const std::vector<CorrelationBin>& bins, double tau_s, std::size_t channel) {
  double xx = 0.0, xy = 0.0;
  for (const auto& bin : bins) {
    if (bin.pairs < kMinBinSamples) continue;
    const double w = static_cast<double>(bin.pairs);
    const double x = std::exp(-bin.mean_gap_s / tau_s);
    xx += w * x * x, xy += w * x * bin_rho(bin, channel);
  }
  FractionFit fit;
  fit.fraction = xx > 0.0 ? std::clamp(xy / xx, 0.0, kMaxCorrelatedFraction) : 0.0;
  for (const auto& bin : bins) {
    if (bin.pairs < kMinBinSamples) continue;
    const double miss = bin_rho(bin, channel) - fit.fraction * std::exp(-bin.mean_gap_s / tau_s);
    fit.misfit += static_cast<double>(bin.pairs) * miss * miss;
  }
  return fit;
}

double correlation_time_candidate(int step) {
  const double ratio = std::log(kMaxCorrelationTimeS / kMinCorrelationTimeS) / kCorrelationTimeSteps;
  return kMinCorrelationTimeS * std::exp(ratio * step);
}

/// The τ of the grid minimising the summed misfit of the channels asked for (each with its own c).
double best_correlation_time(const std::vector<CorrelationBin>& bins, bool range, bool bearing) {
  double best_tau = 0.0;
  double best_misfit = std::numeric_limits<double>::infinity();
  for (int step = 0; step <= kCorrelationTimeSteps; ++step) {
    const double tau = correlation_time_candidate(step);
    const double misfit = (range ? fit_fraction(bins, tau, 0).misfit : 0.0) +
                          (bearing ? fit_fraction(bins, tau, 1).misfit : 0.0);
    if (misfit < best_misfit) best_misfit = misfit, best_tau = tau;
  }
  return best_tau;
}

SightingCorrelation fit_correlation(const std::vector<ConsecutivePair>& pairs) {
  SightingCorrelation out;
  out.pairs = pairs.size();
  out.bins = correlation_bins(pairs);
  const bool fittable = std::any_of(out.bins.begin(), out.bins.end(),
                                    [](const auto& bin) { return bin.pairs >= kMinBinSamples; });
  if (!fittable) return out;
  out.range_only_time_s = best_correlation_time(out.bins, true, false);
  out.bearing_only_time_s = best_correlation_time(out.bins, false, true);
  const double tau = best_correlation_time(out.bins, true, true);
  out.range_fraction = fit_fraction(out.bins, tau, 0).fraction;
  out.bearing_fraction = fit_fraction(out.bins, tau, 1).fraction;
  // Nothing correlated: independent sightings, which τ = 0 says to the filters.
  out.correlation_time_s = out.range_fraction > 0.0 || out.bearing_fraction > 0.0 ? tau : 0.0;
  return out;
}

SightingCalibration calibrate_sightings(const std::vector<SightingResidual>& sightings, std::size_t gaps,
                                        PairTrim trim) {
  SightingCalibration out;
  out.skipped_gap = gaps;
  std::vector<Pair> residuals;
  residuals.reserve(sightings.size());
  for (const auto& s : sightings) residuals.push_back(s.residual);
  const auto stats = robust_pair_stats(residuals, trim);
  out.range_m = stats[0];
  out.bearing_rad = stats[1];
  out.range_bins = range_bins(sightings, out.range_m, out.bearing_rad, trim);
  std::tie(out.range_std_intercept_m, out.range_std_slope) = fit_std_line(out.range_bins);
  out.correlation = fit_correlation(consecutive_pairs(sightings, out.range_m, out.bearing_rad, trim));
  out.same_frame = same_frame_bins(sightings, out.range_m, out.bearing_rad, trim);
  out.cluster_radius_m = cluster_radius(out.same_frame);
  return out;
}

/// Least squares of the inliers' range residual on (1, β, β²), the trim taken again once on what is left.
BearingRangeBias fit_bearing_range_bias(const std::vector<SightingResidual>& sightings, PairTrim trim) {
  BearingRangeBias bias;
  std::vector<Pair> residuals;
  residuals.reserve(sightings.size());
  for (const auto& s : sightings) residuals.push_back(s.residual);
  auto stats = robust_pair_stats(residuals, trim);
  bias.std_before_m = stats[0].std;
  for (int pass = 0; pass < 2; ++pass) {
    Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
    Eigen::Vector3d moment = Eigen::Vector3d::Zero();
    std::size_t used = 0;
    for (std::size_t k = 0; k < sightings.size(); ++k) {
      if (!within_trim(residuals[k], stats[0], stats[1], trim)) continue;
      const double beta = sightings[k].measured_bearing_rad;
      const Eigen::Vector3d row(1.0, beta, beta * beta);
      normal += row * row.transpose();
      moment += row * (sightings[k].residual[0]);
      ++used;
    }
    const Eigen::LDLT<Eigen::Matrix3d> solve(normal);
    if (used < 3 * kMinBinSamples || solve.info() != Eigen::Success) return BearingRangeBias{};
    const Eigen::Vector3d c = solve.solve(moment);
    bias = {c[0], c[1], c[2], used, bias.std_before_m, 0.0};
    for (std::size_t k = 0; k < sightings.size(); ++k) {
      residuals[k][0] = sightings[k].residual[0] - bias.at(sightings[k].measured_bearing_rad);
    }
    stats = robust_pair_stats(residuals, trim);
  }
  bias.std_after_m = stats[0].std;
  return bias;
}

/// Every residual of one robot (or of all, appended), before the statistics.
struct RawResiduals {
  SightingResiduals sightings;
  std::vector<WindowResiduals> windows;  ///< per options.windows_s
};

void append(RawResiduals& into, const RawResiduals& from) {
  auto& s = into.sightings;
  s.landmarks.insert(s.landmarks.end(), from.sightings.landmarks.begin(), from.sightings.landmarks.end());
  s.robots.insert(s.robots.end(), from.sightings.robots.begin(), from.sightings.robots.end());
  s.landmark_gaps += from.sightings.landmark_gaps;
  s.robot_gaps += from.sightings.robot_gaps;
  into.windows.resize(from.windows.size());
  for (std::size_t k = 0; k < from.windows.size(); ++k) {
    auto& w = into.windows[k];
    w.windows.insert(w.windows.end(), from.windows[k].windows.begin(), from.windows[k].windows.end());
    w.gaps += from.windows[k].gaps;
  }
}

RobotCalibration calibrate_residuals(const RawResiduals& raw, const CalibrationOptions& options) {
  RobotCalibration out;
  out.landmarks =
      calibrate_sightings(raw.sightings.landmarks, raw.sightings.landmark_gaps, options.sighting_trim());
  out.robots = calibrate_sightings(raw.sightings.robots, raw.sightings.robot_gaps, options.sighting_trim());
  for (std::size_t k = 0; k < options.windows_s.size(); ++k) {
    out.odometry.push_back(calibrate_odometry(raw.windows[k], options.windows_s[k], options.odometry_trim()));
  }
  return out;
}

}  // namespace

bool PairTrim::inside(double z0, double z1) const {
  if (shape == Shape::joint) return z0 * z0 + z1 * z1 <= threshold;
  return std::abs(z0) <= threshold && std::abs(z1) <= threshold;
}

double PairTrim::standardized(double deviation, double std) {
  if (std > 0.0) return deviation / std;
  return deviation == 0.0 ? 0.0 : std::numeric_limits<double>::infinity();
}

double PairTrim::variance_factor() const {
  if (shape == Shape::joint) {
    // The squared radius of a unit bivariate Gaussian is χ²(2), exponential with mean 2: E[r² | r² ≤ k] per
    // channel, halved.
    const double tail = std::exp(-0.5 * threshold);
    return 1.0 - 0.5 * threshold * tail / (1.0 - tail);
  }
  // One channel truncated to ±k (the other channel's box does not change it: the channels are independent).
  const double density = std::exp(-0.5 * threshold * threshold) / std::sqrt(2.0 * std::numbers::pi);
  const double mass = std::erf(threshold / std::numbers::sqrt2);
  return 1.0 - 2.0 * threshold * density / mass;
}

std::array<RobustStats, 2> robust_pair_stats(const std::vector<Pair>& residuals, PairTrim trim) {
  std::array<RobustStats, 2> out{};
  for (auto& s : out) s.samples = residuals.size();
  if (residuals.size() < 2) return out;
  std::array<ChannelEstimate, 2> est{median_mad(residuals, 0), median_mad(residuals, 1)};
  const double factor = trim.variance_factor();
  std::vector<bool> mask = inlier_mask(residuals, est, trim);
  for (int iteration = 0; iteration < 100; ++iteration) {
    est = inlier_moments(residuals, mask, factor);
    auto next = inlier_mask(residuals, est, trim);
    if (next == mask) break;
    mask = std::move(next);
  }
  const auto outliers = static_cast<std::size_t>(std::count(mask.begin(), mask.end(), false));
  const auto plain = inlier_moments(residuals, std::vector<bool>(residuals.size(), true), 1.0);
  const auto all = inlier_moments(residuals, inlier_mask(residuals, plain, PairTrim::per_channel(5.0)),
                                  PairTrim::per_channel(5.0).variance_factor());
  for (std::size_t c = 0; c < 2; ++c) {
    out[c].all_std = all[c].scale;
    out[c].all_mean = all[c].centre;
    out[c].outliers = outliers;
    out[c].bias = est[c].centre;
    out[c].std = est[c].scale;
  }
  return out;
}

std::optional<MrclamDataset::TimedPose> groundtruth_at(const std::vector<GroundtruthPose>& track,
                                                       double time_s, double max_gap_s) {
  const auto after =
      std::lower_bound(track.begin(), track.end(), time_s,
                       [](const GroundtruthPose& pose, double time) { return pose.time_s < time; });
  if (after == track.end()) return std::nullopt;
  if (after->time_s == time_s) return *after;
  if (after == track.begin()) return std::nullopt;
  const auto before = std::prev(after);
  const double span = after->time_s - before->time_s;
  if (span > max_gap_s) return std::nullopt;
  const double w = (time_s - before->time_s) / span;
  const double turn = models::wrap_angle(after->heading_rad - before->heading_rad);
  return GroundtruthPose{time_s, (1.0 - w) * before->position_m + w * after->position_m,
                         models::wrap_angle(before->heading_rad + w * turn)};
}

MrclamCalibration calibrate_mrclam(const MrclamDataset& data, const CalibrationOptions& options) {
  MrclamCalibration out;
  out.options = options;
  std::vector<SightingResiduals> sightings;
  std::vector<SightingResidual> pooled_landmarks;
  for (std::size_t r = 0; r < data.robots.size(); ++r) {
    sightings.push_back(sighting_residuals(data, r, options.max_groundtruth_gap_s));
    const auto& landmarks = sightings.back().landmarks;
    pooled_landmarks.insert(pooled_landmarks.end(), landmarks.begin(), landmarks.end());
  }
  out.range_bias = fit_bearing_range_bias(pooled_landmarks, options.sighting_trim());
  out.odometry_lag =
      detail::measure_odometry_lag(data, options.max_groundtruth_gap_s, options.odometry_trim());
  const double lag = out.odometry_lag.lag_s;
  RawResiduals pooled;
  pooled.windows.resize(options.windows_s.size());
  for (std::size_t r = 0; r < data.robots.size(); ++r) {
    RawResiduals raw;
    raw.sightings = std::move(sightings[r]);
    for (auto* kind : {&raw.sightings.landmarks, &raw.sightings.robots}) {
      for (auto& s : *kind) s.residual[0] -= out.range_bias.at(s.measured_bearing_rad);
    }
    for (double window : options.windows_s) {
      raw.windows.push_back(odometry_residuals(data.robots[r], window, options.max_groundtruth_gap_s, lag));
    }
    out.robots.push_back(calibrate_residuals(raw, options));
    append(pooled, raw);
  }
  out.pooled = calibrate_residuals(pooled, options);

  // The horizon needs the pooled correlation time, so its windows come second; on the data step's grid.
  const double tau = out.pooled.landmarks.correlation.correlation_time_s;
  const double horizon_s = std::max(options.min_horizon_s, 0.1 * std::round(tau / 0.1));
  WindowResiduals pooled_horizon;
  for (std::size_t r = 0; r < data.robots.size(); ++r) {
    WindowResiduals raw = odometry_residuals(data.robots[r], horizon_s, options.max_groundtruth_gap_s, lag);
    out.robots[r].horizon = calibrate_odometry(raw, horizon_s, options.odometry_trim());
    pooled_horizon.windows.insert(pooled_horizon.windows.end(), raw.windows.begin(), raw.windows.end());
    pooled_horizon.gaps += raw.gaps;
  }
  out.pooled.horizon = calibrate_odometry(pooled_horizon, horizon_s, options.odometry_trim());
  return out;
}

}  // namespace swarmloc::world
