// The MURP range calibration (docs/real-data.md, "MURP range calibration"): on synthetic trials built from
// known poses with a known bias and counter-based noise (deterministic), and on the real calibration trials
// 01-12 when the dataset is present (tests/support/dataset_paths.hpp; skipped with a message otherwise).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "dataset_paths.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/core/random.hpp"
#include "swarmloc/world/murp_calibration.hpp"

namespace swarmloc::world {
namespace {

using estimators::uwb::RangeBias;

struct SyntheticRanges {
  std::array<std::array<double, kMurpAntennas>, kMurpVehicles> offsets_m{};
  RangeBias::Features coefficients_m = RangeBias::Features::Zero();
  double noise_floor_m = 0.002;
  double spread_gain = 0.0;  ///< the noise of a range grows as √(floor² + (gain·spread²)²)
  bool varied_spread = false;
  /// This fraction of the ranges reads gross_error_m long (a reflection taken for the direct path).
  double gross_error_fraction = 0.0;
  double gross_error_m = 1.0;
};

SyntheticRanges known_bias() {
  SyntheticRanges truth;
  for (int v = 0; v < kMurpVehicles; ++v) {
    for (int i = 0; i < kMurpAntennas; ++i) {
      truth.offsets_m[static_cast<std::size_t>(v)][static_cast<std::size_t>(i)] =
          0.03 * (v - 1) + 0.01 * ((3 * v + 5 * i) % 7 - 3);
    }
  }
  truth.coefficients_m << 0.12, -0.06, 0.03, 0.02, -0.015;
  return truth;
}

/// Vehicle v (0-based) in window k: on its own circle (radii 1.0, 2.5, 4.0 m, so the vehicles never meet),
/// turning, slightly tilted; vehicle 0 high (1.75 m) as in the dataset, the others low.
MurpPose synthetic_pose(int v, int k) {
  const double t = k;
  MurpPose pose;
  const double radius = 1.0 + 1.5 * v + 0.3 * std::sin(0.13 * t + v);
  const double angle = 0.11 * (v + 1) * t + 2.1 * v;
  const double height = v == 0 ? 1.75 + 0.1 * std::sin(0.3 * t) : 0.5 + 0.05 * std::sin(0.2 * t + v);
  pose.position_m = Vec3(radius * std::cos(angle), radius * std::sin(angle), height);
  pose.yaw_rad = (v % 2 == 0 ? 0.37 : -0.29) * t + v;
  pose.roll_rad = 0.03 * std::sin(0.5 * t + v);
  pose.pitch_rad = 0.02 * std::cos(0.4 * t + v);
  return pose;
}

double synthetic_spread(const SyntheticRanges& truth, std::uint64_t key) {
  if (!truth.varied_spread) return 0.05;
  // As in the dataset: most windows' readings agree to within about 0.1 m, one in seven spread wider
  // (from 0.2 m to 1 m, most of them near 0.2 m).
  const double u = core::unit_uniform(core::mix64(key ^ 0x9e37U));
  return u < 6.0 / 7.0 ? 0.01 + 0.11 * u * 7.0 / 6.0 : 0.2 + 0.8 * std::pow(7.0 * (u - 6.0 / 7.0), 4.0);
}

/// What the calibration fits: offsets of both antennas and the geometry term.
double true_bias(const SyntheticRanges& truth, int base, int target, int i, int j,
                 const RangeBias::Features& features) {
  return truth.offsets_m[static_cast<std::size_t>(base - 1)][static_cast<std::size_t>(i)] +
         truth.offsets_m[static_cast<std::size_t>(target - 1)][static_cast<std::size_t>(j)] +
         truth.coefficients_m.dot(features);
}

MurpWindow synthetic_window(const SyntheticRanges& truth, int base, int target, int k) {
  MurpWindow window;
  window.time_s = k;
  window.base = synthetic_pose(base - 1, k);
  window.target = synthetic_pose(target - 1, k);
  for (int i = 0; i < kMurpAntennas; ++i) {
    for (int j = 0; j < kMurpAntennas; ++j) {
      if ((i + 2 * j + k) % 11 == 0) continue;  // no reading: stays NaN
      const auto geometry = murp_pair_geometry(window.base, window.target, i, j);
      const auto key = core::hash_keys(7, k, base, target, i, j);
      const double spread = synthetic_spread(truth, key);
      const double std_m = std::hypot(truth.noise_floor_m, truth.spread_gain * spread * spread);
      const bool gross = core::unit_uniform(core::mix64(key ^ 0x51U)) < truth.gross_error_fraction;
      window.ranges_m(i, j) = geometry.range_m + true_bias(truth, base, target, i, j, geometry.features) +
                              std_m * core::standard_normal(key) + (gross ? truth.gross_error_m : 0.0);
      window.range_std_m(i, j) = spread;
    }
  }
  return window;
}

MurpTrial synthetic_trial(const SyntheticRanges& truth, int windows) {
  MurpTrial trial;
  trial.name = "synthetic";
  for (int base = 1; base <= kMurpVehicles; ++base) {
    for (int target = 1; target <= kMurpVehicles; ++target) {
      if (base == target) continue;
      MurpPairLog log;
      log.base = base;
      log.target = target;
      for (int k = 0; k < windows; ++k) log.windows.push_back(synthetic_window(truth, base, target, k));
      trial.pairs.push_back(log);
    }
  }
  return trial;
}

double fitted_bias(const MurpRangeCalibration& c, int base, int target, int i, int j,
                   const RangeBias::Features& features) {
  return c.antenna_offsets_m[static_cast<std::size_t>(base - 1)][static_cast<std::size_t>(i)] +
         c.antenna_offsets_m[static_cast<std::size_t>(target - 1)][static_cast<std::size_t>(j)] +
         c.coefficients_m.dot(features);
}

double worst_bias_error(const SyntheticRanges& truth, const MurpTrial& trial,
                        const MurpRangeCalibration& fitted) {
  double worst = 0.0;
  for (const auto& log : trial.pairs) {
    for (const auto& window : log.windows) {
      for (int i = 0; i < kMurpAntennas; ++i) {
        for (int j = 0; j < kMurpAntennas; ++j) {
          const auto geometry = murp_pair_geometry(window.base, window.target, i, j);
          const double error = fitted_bias(fitted, log.base, log.target, i, j, geometry.features) -
                               true_bias(truth, log.base, log.target, i, j, geometry.features);
          worst = std::max(worst, std::abs(error));
        }
      }
    }
  }
  return worst;
}

TEST(MurpRangeCalibration, RecoversAKnownBiasForEveryAntennaPairAndGeometry) {
  const auto truth = known_bias();
  const auto trial = synthetic_trial(truth, 120);
  const auto fitted = calibrate_murp_ranges({trial});
  // The bias of every range of the trial, at its geometry, to 1 mm: the offsets of each antenna pair
  // together with the geometry term (a constant could move between the three vehicles' offsets).
  EXPECT_LT(worst_bias_error(truth, trial, fitted), 1e-3);
  for (int f = 0; f < RangeBias::kFeatures; ++f) {
    EXPECT_NEAR(fitted.coefficients_m(f), truth.coefficients_m(f), 5e-3) << "coefficient " << f;
  }
  EXPECT_NEAR(fitted.range_std_m, truth.noise_floor_m, 0.2 * truth.noise_floor_m);
  EXPECT_EQ(fitted.trials, std::vector<std::string>{"synthetic"});
  EXPECT_GT(fitted.ranges_used, 6U * 120U * 30U);
  EXPECT_LT(fitted.ranges_used, 6U * 120U * 36U);  // the NaN ranges are not used
}

/// Least squares would move every bias by about fraction × gross error (30 mm here); the Huber weights
/// hold it to a fraction of the threshold.
TEST(MurpRangeCalibration, GrossErrorsDoNotMoveTheBias) {
  auto truth = known_bias();
  truth.gross_error_fraction = 0.03;
  const auto trial = synthetic_trial(truth, 120);
  const auto fitted = calibrate_murp_ranges({trial});
  EXPECT_LT(worst_bias_error(truth, trial, fitted), 2e-3);
  EXPECT_NEAR(fitted.outlier_fraction, truth.gross_error_fraction, 0.01);
  EXPECT_LT(fitted.range_std_m, 2.0 * truth.noise_floor_m);
}

TEST(MurpRangeCalibration, RecoversTheNoiseFloorAndItsGrowthWithTheReadingsSpread) {
  auto truth = known_bias();
  truth.noise_floor_m = 0.05;
  truth.spread_gain = 1.5;
  truth.varied_spread = true;
  const auto fitted = calibrate_murp_ranges({synthetic_trial(truth, 400)});
  // σ0 is the robust std of all ranges: above the floor by the share of the wide ones (0.056 here).
  EXPECT_GT(fitted.range_std_m, truth.noise_floor_m);
  EXPECT_LT(fitted.range_std_m, 1.15 * truth.noise_floor_m);
  EXPECT_NEAR(fitted.spread_noise_gain, truth.spread_gain, 0.15 * truth.spread_gain);  // 1.41 here
  ASSERT_EQ(fitted.spread_bins.size(), kMurpSpreadEdges.size());
  EXPECT_EQ(fitted.spread_bins.back().to_m, std::numeric_limits<double>::infinity());
  std::size_t binned = 0;
  for (const auto& bin : fitted.spread_bins) binned += bin.ranges;
  EXPECT_EQ(binned, fitted.ranges_used);
  // Gaussian noise: 0.27 % beyond 3 σ where the spread is small, more in the wide bins.
  EXPECT_GT(fitted.outlier_fraction, 0.001);
  EXPECT_LT(fitted.outlier_fraction, 0.2);
}

TEST(MurpRangeCalibration, RefusesTrialsWithTooFewRanges) {
  const auto trial = synthetic_trial(known_bias(), 4);  // 6 pairs × 4 windows × ≤ 36 ranges < 1000
  EXPECT_THROW((void)calibrate_murp_ranges({trial}), config::ScenarioError);
  EXPECT_THROW((void)calibrate_murp_ranges({}), config::ScenarioError);
}

TEST(MurpRangeModel, WithoutCalibrationHasTheRingNoBiasAndTheDefaultNoise) {
  const auto params = murp_range_model(nullptr, 1, 2);
  const estimators::uwb::RelativePoseParams defaults;
  ASSERT_EQ(params.my_lever_arms_m.size(), 6U);
  ASSERT_EQ(params.peer_lever_arms_m.size(), 6U);
  const double angle = std::atan2(params.my_lever_arms_m[2].y(), params.my_lever_arms_m[2].x());
  EXPECT_NEAR(angle, 150.0 * std::numbers::pi / 180.0, 1e-12);  // antenna 3 at 30° + 2·60°
  EXPECT_NEAR(params.peer_lever_arms_m[0].norm(), 0.32, 1e-12);
  EXPECT_EQ(params.bias.my_antenna_offsets_m.size(), 0);
  EXPECT_EQ(params.bias.peer_antenna_offsets_m.size(), 0);
  EXPECT_EQ(params.bias.coefficients_m, RangeBias::Features::Zero());
  EXPECT_EQ(params.range_std_m, defaults.range_std_m);
  EXPECT_EQ(params.spread_noise_gain, defaults.spread_noise_gain);
  EXPECT_EQ(params.heading_walk_radps, 0.2);
  EXPECT_EQ(params.position_walk_mps, 3.0);
}

/// A pose's attitude as the filter takes it, R = Rz(yaw)·Ry(pitch)·Rx(roll), from murp_rotation (which
/// composes the files' angles in another order).
struct ImuAngles {
  double yaw_rad = 0.0;
  estimators::uwb::Tilt tilt;
};
ImuAngles imu_angles(const MurpPose& pose) {
  const Mat3 r = murp_rotation(pose);
  return {std::atan2(r(1, 0), r(0, 0)),
          {std::atan2(r(2, 1), r(2, 2)), -std::asin(std::clamp(r(2, 0), -1.0, 1.0))}};
}

/// The filter's prediction for a window at the true relative pose is the geometric range plus the
/// calibration's bias of (base antenna i, target antenna j): base offsets are "mine", target's the peer's,
/// and the features the filter computes in the base's level frame are those fitted in the world frame.
TEST(MurpRangeModel, GivesTheFilterTheBaseOffsetsAsMineAndTheTargetsAsThePeers) {
  const auto truth = known_bias();
  const auto calibration = calibrate_murp_ranges({synthetic_trial(truth, 60)});
  const auto params = murp_range_model(&calibration, 3, 1);
  EXPECT_EQ(params.range_std_m, calibration.range_std_m);
  EXPECT_EQ(params.spread_noise_gain, calibration.spread_noise_gain);
  const auto window = synthetic_window(truth, 3, 1, 17);
  const auto base = imu_angles(window.base);
  const auto target = imu_angles(window.target);
  estimators::uwb::RangeWindow range_window;
  range_window.ranges_m = window.ranges_m;
  range_window.mine = base.tilt;
  range_window.peer = target.tilt;
  const estimators::uwb::RelativePose pose{
      estimators::uwb::yaw_rotation(-base.yaw_rad) * (window.target.position_m - window.base.position_m),
      target.yaw_rad - base.yaw_rad};
  const auto prediction = estimators::uwb::predict_ranges(pose, range_window, params);
  Eigen::Index row = 0;
  for (int j = 0; j < kMurpAntennas; ++j) {  // predict_ranges lists the valid ranges column by column
    for (int i = 0; i < kMurpAntennas; ++i) {
      if (!std::isfinite(window.ranges_m(i, j))) continue;
      const auto geometry = murp_pair_geometry(window.base, window.target, i, j);
      EXPECT_NEAR(prediction.predicted_m(row),
                  geometry.range_m + fitted_bias(calibration, 3, 1, i, j, geometry.features), 1e-9)
          << "antennas " << i << ", " << j;
      ++row;
    }
  }
  EXPECT_EQ(row, prediction.predicted_m.size());
}

TEST(MurpRangeModel, RejectsVehiclesOutsideTheTeamAndAVehicleRangingToItself) {
  EXPECT_THROW((void)murp_range_model(nullptr, 0, 2), std::invalid_argument);
  EXPECT_THROW((void)murp_range_model(nullptr, 1, 4), std::invalid_argument);
  EXPECT_THROW((void)murp_range_model(nullptr, 2, 2), std::invalid_argument);
}

// --- The real calibration trials ---------------------------------------------------------------------

std::filesystem::path murp_calibration_dataset() {
  const auto dir = testing::murp_parsed(SWARMLOC_SOURCE_DIR);
  return !dir.empty() && std::filesystem::exists(dir) ? dir : std::filesystem::path();
}

std::vector<MurpTrial> calibration_trials(const std::filesystem::path& parsed) {
  std::vector<MurpTrial> trials;
  for (int n = 1; n <= 12; ++n)
    trials.push_back(load_murp_trial(parsed / ((n < 10 ? "0" : "") + std::to_string(n))));
  return trials;
}

TEST(MurpCalibrationTrials, GeometryMatchesTheAuthorsTruthRanges) {
  const auto parsed = murp_calibration_dataset();
  if (parsed.empty()) GTEST_SKIP() << "MIT MURP dataset not found (SWARMLOC_MURP_DIR)";
  const auto trial = load_murp_trial(parsed / "01");
  std::vector<double> errors;
  for (const auto& log : trial.pairs) {
    for (const auto& window : log.windows) {
      for (int i = 0; i < kMurpAntennas; ++i) {
        for (int j = 0; j < kMurpAntennas; ++j) {
          if (!std::isfinite(window.truth_ranges_m(i, j))) continue;
          const auto geometry = murp_pair_geometry(window.base, window.target, i, j);
          errors.push_back(std::abs(geometry.range_m - window.truth_ranges_m(i, j)));
        }
      }
    }
  }
  ASSERT_GT(errors.size(), 1000U);
  // The authors' I_J_t: the same ring, the same rotation (murp_rotation), to rounding.
  EXPECT_LT(*std::max_element(errors.begin(), errors.end()), 1e-6);
}

TEST(MurpCalibrationTrials, Trials01To12GiveTheElevationBiasAndTheNoiseFigures) {
  const auto parsed = murp_calibration_dataset();
  if (parsed.empty()) GTEST_SKIP() << "MIT MURP dataset not found (SWARMLOC_MURP_DIR)";
  const auto fitted = calibrate_murp_ranges(calibration_trials(parsed));
  EXPECT_GT(fitted.range_std_m, 0.06);
  EXPECT_LT(fitted.range_std_m, 0.10);
  EXPECT_GT(fitted.spread_noise_gain, 0.5);
  EXPECT_LT(fitted.spread_noise_gain, 4.0);
  EXPECT_GT(std::abs(fitted.coefficients_m(0)), 0.5) << "the bias grows with the elevation (|s|)";
  EXPECT_GT(fitted.ranges_used, 100000U);
  EXPECT_EQ(fitted.trials.size(), 12U);
}

}  // namespace
}  // namespace swarmloc::world
