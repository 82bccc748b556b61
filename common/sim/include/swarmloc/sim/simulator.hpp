#pragma once
// The in-process runtime: the same AgentRuntime + estimator code as the DDS agents, driven in
// synchronous rounds over a seeded bus that applies the same receiver-side loss model.
#include <functional>

#include "swarmloc/sim/agent_runtime.hpp"
#include "swarmloc/sim/run_record.hpp"

namespace swarmloc::sim {

struct SimOptions {
  bool record_estimates = true;  ///< keep per-agent per-step rows (estimates.csv)
  /// Called after every step with (step, errors) — for progress lines. May be empty.
  std::function<void(std::int64_t, const ErrorStats&)> on_step;
};

/// Runs `scenario` in synchronous rounds: at round k every agent receives its world-step-k batch and
/// the samples its neighbours published in round k−1, then steps. Deterministic in the seed.
RunRecord run_simulation(const config::Scenario& scenario, const SimOptions& options = {});

/// Builds the estimator for agent `id` of `world` from the scenario's algorithm settings.
std::unique_ptr<estimators::Estimator> make_agent_estimator(const config::Scenario& scenario, const World& world,
                                                            AgentId id);
/// Runtime parameters (seed, loss, plausibility bounds) for the scenario.
AgentRuntimeParams make_runtime_params(const config::Scenario& scenario);

}  // namespace swarmloc::sim
