#include "preflight.hpp"

#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "swarmloc/run/manifests.hpp"
#include "swarmloc/runtime/agent_factory.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::orchestrator {

std::optional<config::Scenario> load_scenario_or_report(const std::string& path,
                                                        const std::vector<std::string>& overrides) {
  try {
    std::vector<std::string> warnings;
    auto scenario = config::load_scenario(path, overrides, &warnings);
    for (const auto& warning : warnings) std::fprintf(stderr, "warning: %s\n", warning.c_str());
    return scenario;
  } catch (const config::ScenarioError& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return std::nullopt;
  }
}

void check_hostile_ids(const std::vector<AgentId>& hostile_agents, const config::Scenario& scenario) {
  for (AgentId id : hostile_agents) {
    if (id < 0 || id >= scenario.world.agents) {
      throw config::ScenarioError("--hostile: agent " + std::to_string(id) + " is outside [0, world.agents)");
    }
  }
}

world::World check_runnable(const config::Scenario& scenario, const world::WorkControl& control,
                            std::uint64_t trial) {
  auto world = world::build_world(scenario, trial, -1, control);
  try {
    (void)runtime::make_agent_estimator(scenario,
                                        run::agent_manifest(run::shared_manifest(scenario, world), world, 0));
  } catch (const std::invalid_argument& error) {
    throw config::ScenarioError("algorithm.name: '" + scenario.algorithm.name +
                                "' is not runnable by swarmloc run/sim yet (" + error.what() + ")");
  }
  return world;
}

}  // namespace swarmloc::orchestrator
