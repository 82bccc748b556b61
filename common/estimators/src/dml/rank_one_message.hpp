#pragma once
// The rank-one range messages of dml and dml_track (docs/algorithms.md §9.3, §9.8).

#include <cmath>

namespace swarmloc::estimators::rank_one {

inline constexpr double kShortestDistanceM = 1e-9;  // below it a range has no direction to linearize along
inline constexpr double kCavityTolerance = 1e-9;

/// The scale s of the rank-one range message s·aaᵀ: the range's information after the far end's
/// variance along the edge is added to the range's own variance; 0 without information on either side.
inline double message_scale(double range_information, double far_end_variance) {
  if (!std::isfinite(far_end_variance) || !(range_information > 0.0)) return 0.0;
  return 1.0 / (1.0 / range_information + far_end_variance);
}

}  // namespace swarmloc::estimators::rank_one
