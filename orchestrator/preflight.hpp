#pragma once
// Checks of a loaded scenario before anything starts; each throws config::ScenarioError (exit 2).
#include <optional>
#include <string>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/core/types.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::orchestrator {

/// The scenario file with its --set overrides; on bad input prints "error: ..." to stderr and returns
/// nullopt (the caller exits 2). Algorithm keys the algorithm does not read print "warning: ...".
std::optional<config::Scenario> load_scenario_or_report(const std::string& path,
                                                        const std::vector<std::string>& overrides);

/// --hostile ids inside [0, world.agents).
void check_hostile_ids(const std::vector<AgentId>& hostile_agents, const config::Scenario& scenario);
/// Builds the world and one agent's estimator, so that an unplaceable world or an algorithm this runtime
/// cannot run yet is reported as bad input naming the key. Returns the world, for the run to use rather
/// than build it again (minutes at 10^5 agents). `control`: progress and Ctrl-C while building (throws
/// world::Cancelled). `trial`: the Monte Carlo trial whose world it is (World::trial).
world::World check_runnable(const config::Scenario& scenario, const world::WorkControl& control = {},
                            std::uint64_t trial = 0);

}  // namespace swarmloc::orchestrator
