#pragma once
// One vehicle of a team that localizes its peers relative to itself from inter-vehicle UWB ranges
// (docs/algorithms.md §11): a RelativePoseFilter per peer fed by this vehicle's own antennas, then loop
// closure with what the peers estimate of each other. Each window takes two rounds: observe() with the
// window's ranges and every vehicle's IMU and altimeter readings (published by each vehicle), then fuse()
// with the peers' own-range estimates (published after their observe()). No transport, clock, RNG, I/O or
// logging inside.
#include <map>
#include <optional>
#include <vector>

#include "swarmloc/estimators/uwb/relative_pose.hpp"

namespace swarmloc::estimators::uwb {

/// What a vehicle's own IMU and altimeter give it for one window.
struct VehicleSensing {
  Tilt tilt;
  double turn_rad = 0.0;             ///< heading change since the previous window (gyro)
  std::optional<double> altitude_m;  ///< nullopt: no altimeter reading
};

/// This vehicle's window of ranges to one peer: ranges_m(i, j) from my antenna i to the peer's antenna j.
struct PeerRanges {
  AgentId peer = 0;
  MatX ranges_m;
  MatX spread_m;  ///< may be empty
};

class TeamMember {
 public:
  /// `models` holds the range model of each peer (lever arms of both vehicles, bias, noise).
  TeamMember(AgentId me, const std::map<AgentId, RelativePoseParams>& models);

  /// Round 1. Advances every peer's filter by dt_s and folds in this window's ranges to it; a peer whose
  /// sensing is missing is predicted with no turn and its last known tilt. Returns my own-range estimate of
  /// every peer whose filter has been initialized (what I publish).
  std::map<AgentId, PoseEstimate> observe(double dt_s, const VehicleSensing& mine,
                                          const std::map<AgentId, VehicleSensing>& peers,
                                          const std::vector<PeerRanges>& ranges);

  /// Round 2. My own-range estimates fused with the peers' estimates of each other (fuse_team); relations
  /// from me or to me are ignored; the order they arrive in does not matter.
  [[nodiscard]] std::map<AgentId, PoseEstimate> fuse(const std::vector<PeerRelation>& relations) const;

  [[nodiscard]] AgentId id() const { return me_; }
  [[nodiscard]] std::map<AgentId, PoseEstimate> own_estimates() const;

 private:
  AgentId me_;
  std::map<AgentId, RelativePoseFilter> filters_;
  std::map<AgentId, Tilt> last_tilt_;
};

}  // namespace swarmloc::estimators::uwb
