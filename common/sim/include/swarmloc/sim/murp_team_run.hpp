#pragma once
// The in-process runner of a MURP trial (`swarmloc replay --murp DIR --sim`): one TeamMember per vehicle,
// each window in the two rounds the DDS agents run (docs/real-data.md, "MURP"): every vehicle observes its own
// ranges with the others' published IMU and altimeter readings, then fuses its estimates with the others'
// published own-range estimates.
#include <map>
#include <utility>
#include <vector>

#include "swarmloc/estimators/uwb/team_member.hpp"
#include "swarmloc/world/murp_team.hpp"

namespace swarmloc::sim {

struct MurpTeamOptions {
  /// The range model of each ordered pair (base, target): what the base uses for its ranges to the target.
  std::map<std::pair<AgentId, AgentId>, estimators::uwb::RelativePoseParams> models;
  bool cooperate = true;  ///< false: every vehicle reports its own-range estimates (no loop closure)
};

/// The range model of each vehicle for its peers, from the per-pair models.
std::map<AgentId, estimators::uwb::RelativePoseParams> member_models(const MurpTeamOptions& options,
                                                                     AgentId me);

/// Every vehicle's reported estimate of every peer it has localized, window by window.
std::vector<world::RelativeEstimateRow> run_murp_team(const std::vector<world::MurpTeamWindow>& windows,
                                                      const MurpTeamOptions& options);

}  // namespace swarmloc::sim
