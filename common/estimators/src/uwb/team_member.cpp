#include "swarmloc/estimators/uwb/team_member.hpp"

#include <algorithm>
#include <utility>

namespace swarmloc::estimators::uwb {

TeamMember::TeamMember(AgentId me, const std::map<AgentId, RelativePoseParams>& models) : me_(me) {
  for (const auto& [peer, params] : models) {
    if (peer != me) filters_.emplace(peer, RelativePoseFilter(params));
  }
}

std::map<AgentId, PoseEstimate> TeamMember::observe(double dt_s, const VehicleSensing& mine,
                                                    const std::map<AgentId, VehicleSensing>& peers,
                                                    const std::vector<PeerRanges>& ranges) {
  for (auto& [peer, filter] : filters_) {
    const auto sensed = peers.find(peer);
    if (sensed != peers.end()) last_tilt_[peer] = sensed->second.tilt;
    filter.predict(dt_s, mine.turn_rad, sensed != peers.end() ? sensed->second.turn_rad : 0.0);
  }
  for (const auto& window : ranges) {
    const auto filter = filters_.find(window.peer);
    if (filter == filters_.end()) continue;
    const auto sensed = peers.find(window.peer);
    RangeWindow range_window{window.ranges_m, window.spread_m, mine.tilt, last_tilt_[window.peer],
                             std::nullopt};
    if (sensed != peers.end() && mine.altitude_m && sensed->second.altitude_m) {
      range_window.altitude_difference_m = *sensed->second.altitude_m - *mine.altitude_m;
    }
    filter->second.update(range_window);
  }
  return own_estimates();
}

std::map<AgentId, PoseEstimate> TeamMember::own_estimates() const {
  std::map<AgentId, PoseEstimate> estimates;
  for (const auto& [peer, filter] : filters_) {
    if (filter.initialized()) estimates[peer] = {filter.pose(), filter.covariance()};
  }
  return estimates;
}

std::map<AgentId, PoseEstimate> TeamMember::fuse(const std::vector<PeerRelation>& relations) const {
  std::vector<PeerRelation> among_peers;
  for (const auto& relation : relations) {
    if (relation.from != me_ && relation.to != me_) among_peers.push_back(relation);
  }
  // The same relations in any arrival order give the same floating-point result.
  std::sort(among_peers.begin(), among_peers.end(), [](const PeerRelation& a, const PeerRelation& b) {
    return std::pair(a.from, a.to) < std::pair(b.from, b.to);
  });
  return fuse_team(own_estimates(), among_peers);
}

}  // namespace swarmloc::estimators::uwb
