#pragma once
// The fusion-centre process (docs/design.md §1; docs/algorithms.md §2.7): for a centralized algorithm (ekf,
// lbekf, lbekf_vr, lbekf_i) one process holds the whole network state. Each world step it collects
// every agent's measurement batch, steps the filter and publishes every agent's estimate. Same binary
// as the agents: `swarmloc agent --role fusion --scenario FILE`.
#include <string>
#include <vector>

namespace swarmloc::orchestrator {

struct FusionOptions {
  std::string scenario_path;
  std::vector<std::string> overrides;
  std::string log_path;  ///< empty: log to stderr
};

/// Runs the fusion centre until STOP, SIGINT/SIGTERM or the orchestrator goes silent. Returns the
/// process exit code (0 ok, 2 bad input, 1 runtime failure).
int run_fusion_center(const FusionOptions& options);

}  // namespace swarmloc::orchestrator
