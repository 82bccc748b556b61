#include "run_setup.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <random>
#include <system_error>
#include <utility>

#include "preflight.hpp"
#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/dds/transport.hpp"
#include "swarmloc/rundir/recording.hpp"
#include "swarmloc/rundir/run_record.hpp"
#include "swarmloc/runtime/world_pacing.hpp"

namespace swarmloc::orchestrator {
namespace {

/// dds.security_dir made absolute, and every participant's files (ours; launched agents' and fusion
/// centre's) checked to exist.
void check_security(config::Scenario& scenario, const RunOptions& options) {
  if (scenario.dds.security_dir.empty()) return;
  // Agents read the run directory's scenario.yaml, possibly from another working directory.
  scenario.dds.security_dir = std::filesystem::absolute(scenario.dds.security_dir).lexically_normal();
  dds::security_files(scenario.dds.security_dir, kOrchestratorId);
  if (options.launch_agents) {
    for (AgentId id = 0; id < scenario.world.agents; ++id) dds::security_files(scenario.dds.security_dir, id);
    if (config::runs_in_fusion_centre(scenario.algorithm.name)) {
      dds::security_files(scenario.dds.security_dir, dds::kFusionCenterId);
    }
  }
}

}  // namespace

int run_orchestrator(const RunOptions& options) {
  auto scenario = load_scenario_or_report(options.scenario_path, options.overrides);
  return scenario ? run_orchestrator(std::move(*scenario), options) : 2;
}

std::string fresh_run_id() {
  std::random_device entropy;
  const std::uint64_t value = (static_cast<std::uint64_t>(entropy()) << 32) ^ entropy();
  char text[24];
  std::snprintf(text, sizeof text, "r%012llx", static_cast<unsigned long long>(value & 0xffffffffffffULL));
  return text;
}

world::World prepare_run(config::Scenario& scenario, const RunOptions& options,
                         const world::WorkControl& control, std::filesystem::path& run_dir,
                         bool& run_dir_existed) {
  check_hostile_ids(options.hostile_agents, scenario);
  dds::require_ports_fit(scenario);
  dds::require_ports_clear_of(scenario, dds::ephemeral_port_range());
  check_security(scenario, options);
  // An unusable --out is bad input, found before any work (docs/robustness.md, "Outputs").
  run_dir = options.out_dir.empty() ? rundir::default_run_directory(scenario) : options.out_dir;
  std::error_code ignored;
  run_dir_existed = std::filesystem::exists(run_dir, ignored);
  rundir::prepare_run_directory(run_dir, options.force);
  // Placement and algorithm errors are bad input, found before anything starts; the world built for
  // the check is the run's.
  if (options.record && scenario.world.dimensions == 3)
    throw config::ScenarioError("--record keeps planar worlds only; this one has world.dimensions: 3");
  if (options.trial > 0 && config::runs_in_fusion_centre(scenario.algorithm.name))
    throw config::ScenarioError(
        "--trial: the fusion centre of '" + scenario.algorithm.name +
        "' builds the first trial's world; run other trials with `swarmloc sim --trial`");
  return check_runnable(scenario, control, options.trial);
}

std::unique_ptr<dds::ManifestPublisher> offer_manifests(const config::Scenario& scenario,
                                                        const std::vector<runtime::AgentManifest>& manifests,
                                                        bool launch_agents) {
  if (launch_agents) return nullptr;
  auto publisher = std::make_unique<dds::ManifestPublisher>(scenario, static_cast<int>(manifests.size()));
  publisher->publish(manifests, config::to_yaml(scenario));
  return publisher;
}

runtime::LivenessLimits liveness_limits(const config::Scenario& scenario, bool lockstep) {
  runtime::LivenessLimits limits;
  const double period_s = 1.0 / scenario.run.rate_hz;
  limits.restart_grace_s = scenario.run.startup_timeout_s;
  if (lockstep) {
    limits.stall_s = scenario.run.startup_timeout_s;
  } else {
    limits.current_s = std::max(0.25, 3.0 * period_s);
    limits.stall_s = std::max(2.0, 5.0 * period_s);
  }
  return limits;
}

std::string raise_world_priority() {
  const std::string refused = runtime::raise_world_priority();
  if (refused.empty()) return "realtime";
  spdlog::info("world loop at normal priority (real-time refused: {}); a saturated machine can delay it",
               refused);
  return "normal";
}

}  // namespace swarmloc::orchestrator
