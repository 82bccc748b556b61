#pragma once
// A MURP trial as the team sees it, window by window (docs/real-data.md, "MURP"): what each vehicle's own
// sensors give it (its ranges to each peer from its own antennas, its IMU's tilt and turn, its altimeter),
// and the truth a scorer compares relative estimates with. The IMU and altimeter readings are the
// motion-capture window pose (roll, pitch, the yaw change since the previous window, z; the attitude turned
// into the yaw, pitch, roll an IMU reports), which is what the sensors would give up to their own small
// errors.
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "swarmloc/estimators/uwb/team_member.hpp"
#include "swarmloc/world/murp.hpp"

namespace swarmloc::world {

struct MurpTeamWindow {
  std::int64_t index = 0;
  double time_s = 0.0;
  double dt_s = 0.0;  ///< since the previous window (0 for the first)
  /// Per vehicle (1–3): its own IMU and altimeter, and its ranges to each peer (its base files' rows).
  std::map<AgentId, estimators::uwb::VehicleSensing> sensing;
  std::map<AgentId, std::vector<estimators::uwb::PeerRanges>> ranges;
  /// Per ordered pair (base, target): the target's pose in the base's level frame, recomputed from the two
  /// window poses (the files' own relative columns are window averages: docs/real-data.md, "MURP").
  std::map<std::pair<AgentId, AgentId>, estimators::uwb::RelativePose> truth;
};

/// The trial's windows in time order; a window is kept when at least one pair has it. A vehicle's pose in a
/// window comes from the first pair file that has the window (the files agree on it).
std::vector<MurpTeamWindow> murp_team_windows(const MurpTrial& trial);

/// Relative errors pooled over windows (position in metres, heading in degrees).
struct RelativeErrorStats {
  std::int64_t windows = 0;
  double position_abs_sum_m = 0.0;
  double position_sq_sum_m2 = 0.0;
  double heading_abs_sum_deg = 0.0;
  double range_normalized_sum = 0.0;  ///< Σ position error / true distance
  double distance_sum_m = 0.0;
  void add(const estimators::uwb::RelativePose& estimate, const estimators::uwb::RelativePose& truth);
  void add(const RelativeErrorStats& other);
  [[nodiscard]] double position_mae_m() const;
  [[nodiscard]] double position_rmse_m() const;
  [[nodiscard]] double heading_mae_deg() const;
  [[nodiscard]] double range_normalized_mae() const;  ///< mean of error ÷ distance
  [[nodiscard]] double mean_distance_m() const;
};

/// One vehicle's estimate of one peer in one window, as it reported it.
struct RelativeEstimateRow {
  std::int64_t window = 0;
  AgentId base = 0;    ///< the vehicle that estimates
  AgentId target = 0;  ///< the peer it estimates
  estimators::uwb::PoseEstimate estimate;
};

/// Pooled and per-pair errors of a run's estimates against the windows' truth. A row without truth (its
/// pair has no file row in that window) is not scored.
struct MurpScore {
  RelativeErrorStats pooled;
  std::map<std::pair<AgentId, AgentId>, RelativeErrorStats> per_pair;
  std::int64_t unscored_rows = 0;
  /// Ordered pairs × windows with truth but no estimate (a vehicle had not localized that peer yet).
  std::int64_t missing_estimates = 0;
};
MurpScore score_murp(const std::vector<MurpTeamWindow>& windows,
                     const std::vector<RelativeEstimateRow>& rows);

/// Position error and absolute heading error (rad, wrapped) of one estimate.
std::pair<double, double> relative_errors(const estimators::uwb::RelativePose& estimate,
                                          const estimators::uwb::RelativePose& truth);

}  // namespace swarmloc::world
