#pragma once
// One agent = one OS process: its estimator runs on a timer of its own (skewed, drifting) clock and
// talks to its neighbours over DDS. All estimator-facing logic lives in sim::AgentRuntime; this file
// only moves samples between DDS and that runtime. What the agent knows is its scenario file and its
// manifest (runtime/manifest.hpp): it never builds the world.
#include <functional>
#include <string>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/core/types.hpp"
#include "swarmloc/runtime/manifest.hpp"

namespace swarmloc::agent {

struct AgentOptions {
  std::string scenario_path;
  std::string manifest_path;  ///< the orchestrator's <run>/manifests/agent_<id>.json
  std::vector<std::string> overrides;
  AgentId id = -1;          ///< < 0: the manifest's; else it must match the manifest
  std::string log_path;     ///< empty: log to stderr
  bool hostile = false;     ///< publish NaN / non-PSD / absurd states (robustness tests)
  int incarnation = 0;      ///< restarts so far (faults.kill): numbers samples from a new range
  std::string record_path;  ///< non-empty: log every inter-agent sample received to this file (--record)
  int world_draw = -1;      ///< `swarmloc agent` without --manifest: the world draw (sim::build_world)
};

/// Where the agent's manifest comes from once its scenario is loaded: the file (load_manifest_file), or
/// in the full `swarmloc agent` without --manifest, a world built from the scenario. Throws
/// config::ScenarioError or sim::ManifestError for bad input (exit code 2).
using ManifestSource = std::function<sim::AgentManifest(const config::Scenario&, const AgentOptions&)>;

/// options.manifest_path, loaded and validated.
sim::AgentManifest load_manifest_file(const config::Scenario& scenario, const AgentOptions& options);

/// Runs the agent until STOP, SIGINT/SIGTERM or the orchestrator goes silent. Returns the process
/// exit code (0 ok, 2 bad input, 1 runtime failure).
int run_agent(const AgentOptions& options, const ManifestSource& manifest_source = load_manifest_file);

}  // namespace swarmloc::agent
