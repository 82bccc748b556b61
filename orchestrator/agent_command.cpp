#include "agent_command.hpp"

#include "swarmloc/sim/simulator.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::orchestrator {
namespace {

/// Agent options.id's manifest from the world the scenario describes (what the orchestrator computed).
sim::AgentManifest manifest_from_world(const config::Scenario& scenario, const agent::AgentOptions& options) {
  if (scenario.dds.run_id.empty()) {
    throw config::ScenarioError(
        "dds.run_id is empty: start agents with the run directory's scenario.yaml (`swarmloc run` writes "
        "the run id there) or pass --set dds.run_id=<the id the orchestrator printed>");
  }
  const sim::World world = sim::build_world(scenario, 0, options.world_draw);
  if (options.id < 0 || options.id >= world.size()) {
    throw config::ScenarioError("--id: " + std::to_string(options.id) + " is outside [0, " +
                                std::to_string(world.size()) + ")");
  }
  return sim::make_agent_manifests(scenario, world).at(static_cast<std::size_t>(options.id));
}

}  // namespace

int run_agent_command(const agent::AgentOptions& options) {
  if (!options.manifest_path.empty()) return agent::run_agent(options);
  return agent::run_agent(options, manifest_from_world);
}

}  // namespace swarmloc::orchestrator
