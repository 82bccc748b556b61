// Odometry against groundtruth over tiled windows: the odometry half of calibrate_mrclam
// (docs/real-data.md, "Noise model"). Private to common/world.
#pragma once

#include <array>
#include <cmath>
#include <vector>

#include "swarmloc/world/mrclam_calibration.hpp"

namespace swarmloc::world::detail {

using Pair = std::array<double, 2>;

/// The final trim of robust_pair_stats, applied to one sample.
inline bool within_trim(const Pair& residual, const RobustStats& first, const RobustStats& second,
                        PairTrim trim) {
  return trim.inside(PairTrim::standardized(residual[0] - first.bias, first.std),
                     PairTrim::standardized(residual[1] - second.bias, second.std));
}

/// One window's residual and the odometry's distance along its chord (for the scale ratio).
struct WindowResidual {
  Pair residual{};  ///< distance (m), heading (rad): groundtruth − odometry
  double odometry_distance_m = 0.0;
  double true_distance_m = 0.0;
};

struct WindowResiduals {
  std::vector<WindowResidual> windows;
  std::size_t gaps = 0;
};

/// Each window of `window_s` tiled along the robot's odometry, groundtruth − odometry (a window with a
/// groundtruth gap inside is counted, not scored). The motion over (t0, t1] is integrated from the commands
/// in force over (t0 − lag_s, t1 − lag_s]: the robot follows its commands lag_s late.
WindowResiduals odometry_residuals(const MrclamDataset::Robot& robot, double window_s, double max_gap_s,
                                   double lag_s = 0.0);

/// The command lag that makes the odometry's turn agree best with the groundtruth: the trimmed heading
/// std over windows of kLagWindowS, pooled over every robot, for each lag on a grid of kLagStepS up to
/// kMaxLagS; the lag where it is least.
OdometryLag measure_odometry_lag(const MrclamDataset& data, double max_gap_s, PairTrim trim);

/// The windows' robust statistics and distance ratio.
OdometryCalibration calibrate_odometry(const WindowResiduals& residuals, double window_s, PairTrim trim);

}  // namespace swarmloc::world::detail
