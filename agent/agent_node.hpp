#pragma once
// One agent = one OS process: its estimator runs on a timer of its own (skewed, drifting) clock and
// talks to its neighbours over DDS. When it steps and what it does with what arrives is the agent loop
// (runtime/agent_loop.hpp), which the simulator drives too; this file moves samples between DDS and that
// loop and holds what only a process has (start-up handshake, control, signals, logs). What the agent
// knows is its scenario file and its manifest (runtime/manifest.hpp): it never builds the world.
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
  /// Without --manifest: how long to wait for the manifest sample over DDS (dds/manifest_topic.hpp).
  double manifest_timeout_s = 60.0;
};

/// Where the agent's manifest comes from once its scenario is loaded (from --scenario, or without it the
/// defaults with --set applied: only its dds keys matter then). It may replace the scenario (a manifest
/// sample carries the run's). Throws config::ScenarioError or runtime::ManifestError for bad input (exit
/// code 2), dds::DdsError when none can be had (exit code 1).
using ManifestSource = std::function<runtime::AgentManifest(config::Scenario&, const AgentOptions&)>;

/// options.manifest_path, loaded and validated; without one, agent options.id's manifest sample over
/// DDS (manifest_source.cpp), whose scenario (with options.overrides) replaces `scenario` unless
/// options.scenario_path was given.
runtime::AgentManifest load_manifest(config::Scenario& scenario, const AgentOptions& options);

/// Runs the agent until STOP, SIGINT/SIGTERM or the orchestrator goes silent. Returns the process
/// exit code (0 ok, 2 bad input, 1 runtime failure).
int run_agent(const AgentOptions& options, const ManifestSource& manifest_source = load_manifest);

}  // namespace swarmloc::agent
