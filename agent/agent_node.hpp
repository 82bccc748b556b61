#pragma once
// One agent = one OS process: its estimator runs on a timer of its own (skewed, drifting) clock and
// talks to its neighbours over DDS. All estimator-facing logic lives in sim::AgentRuntime; this file
// only moves samples between DDS and that runtime.
#include <string>
#include <vector>

#include "swarmloc/core/types.hpp"

namespace swarmloc::agent {

struct AgentOptions {
  std::string scenario_path;
  std::vector<std::string> overrides;
  AgentId id = 0;
  std::string log_path;     ///< empty: log to stderr
  bool hostile = false;     ///< publish NaN / non-PSD / absurd states (robustness tests)
  int incarnation = 0;      ///< restarts so far (faults.kill): numbers samples from a new range
  std::string record_path;  ///< non-empty: log every inter-agent sample received to this file (--record)
  int world_draw = -1;      ///< ≥ 0: the world draw the orchestrator accepted (sim::build_world)
};

/// Runs the agent until STOP, SIGINT/SIGTERM or the orchestrator goes silent. Returns the process
/// exit code (0 ok, 2 bad input, 1 runtime failure).
int run_agent(const AgentOptions& options);

}  // namespace swarmloc::agent
