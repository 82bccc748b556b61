#include "swarmloc/sim/murp_team_run.hpp"

namespace swarmloc::sim {
namespace uwb = estimators::uwb;

std::map<AgentId, uwb::RelativePoseParams> member_models(const MurpTeamOptions& options, AgentId me) {
  std::map<AgentId, uwb::RelativePoseParams> models;
  for (const auto& [pair, params] : options.models) {
    if (pair.first == me) models.emplace(pair.second, params);
  }
  return models;
}

std::vector<world::RelativeEstimateRow> run_murp_team(const std::vector<world::MurpTeamWindow>& windows,
                                                      const MurpTeamOptions& options) {
  std::map<AgentId, uwb::TeamMember> members;
  for (const auto& [pair, params] : options.models) {
    if (!members.contains(pair.first))
      members.emplace(pair.first, uwb::TeamMember(pair.first, member_models(options, pair.first)));
  }
  std::vector<world::RelativeEstimateRow> rows;
  for (const auto& window : windows) {
    std::vector<uwb::PeerRelation> published;
    for (auto& [me, member] : members) {
      const auto own_sensing = window.sensing.find(me);
      if (own_sensing == window.sensing.end()) continue;
      std::map<AgentId, uwb::VehicleSensing> peers(window.sensing);
      peers.erase(me);
      const auto ranges = window.ranges.find(me);
      const auto own =
          member.observe(window.dt_s, own_sensing->second, peers,
                         ranges != window.ranges.end() ? ranges->second : std::vector<uwb::PeerRanges>{});
      for (const auto& [peer, estimate] : own) published.push_back({me, peer, estimate});
    }
    for (auto& [me, member] : members) {
      const auto reported = options.cooperate ? member.fuse(published) : member.own_estimates();
      for (const auto& [peer, estimate] : reported) rows.push_back({window.index, me, peer, estimate});
    }
  }
  return rows;
}

}  // namespace swarmloc::sim
