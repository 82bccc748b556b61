// Where an agent's manifest comes from: the file `swarmloc run` writes for the agents it launches, or,
// for agents started elsewhere (`run --no-launch`, containers, other hosts), the orchestrator's manifest
// sample over DDS, which also carries the run's scenario (docs/design.md, "Agent manifests over DDS").
// Either way the agent never builds the world.
#include <spdlog/spdlog.h>

#include "agent_node.hpp"
#include "swarmloc/dds/manifest_topic.hpp"

namespace swarmloc::agent {

runtime::AgentManifest load_manifest(config::Scenario& scenario, const AgentOptions& options) {
  if (!options.manifest_path.empty()) return runtime::load_manifest(options.manifest_path);
  if (options.id < 0) {
    throw runtime::ManifestError(
        "--id is required without --manifest: the agent waits for agent <id>'s manifest on DDS");
  }
  // The agent's own logger (agent_node.cpp names it agent<id>), so these lines go to --log.
  auto log = spdlog::get("agent" + std::to_string(options.id));
  if (!log) log = spdlog::default_logger();
  const std::string run = scenario.dds.run_id.empty() ? "any run" : "run " + scenario.dds.run_id;
  log->info("agent {}: waiting up to {:.0f} s for its manifest on DDS domain {} ({})", options.id,
            options.manifest_timeout_s, scenario.dds.domain_id, run);
  dds::ManifestWaitStats stats;
  dds::ManifestOffer offer = dds::receive_manifest(scenario, options.id, options.manifest_timeout_s, &stats);
  if (stats.rejected > 0)
    log->warn("agent {}: rejected {} manifest sample(s): {}", options.id, stats.rejected,
              stats.last_rejection);
  // The run's scenario as the orchestrator wrote it; --set still applies (e.g. this host's dds.interface),
  // and one that changes the results is refused by the manifest's results hash.
  if (options.scenario_path.empty()) {
    scenario =
        config::parse_scenario(offer.scenario_yaml, options.overrides,
                               "the run's scenario (agent " + std::to_string(options.id) + "'s manifest)");
  }
  log->info("agent {}: manifest of run {} received ({} agents)", options.id, offer.manifest.run_id,
            offer.manifest.agent_count);
  return std::move(offer.manifest);
}

}  // namespace swarmloc::agent
