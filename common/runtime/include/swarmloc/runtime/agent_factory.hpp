#pragma once
// What an agent builds from its scenario and its manifest: the estimator and the scenario-derived
// models it needs (the target's motion, the field's grid). The DDS agent and the simulator call the same
// functions, so lockstep over DDS stays the simulator bit for bit.
#include <memory>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/runtime/manifest.hpp"

namespace swarmloc::runtime {

/// What an agent runs when the algorithm is centralized: nothing. It publishes no inter-agent
/// samples and reports its prior (initial guess, initial_std_m² · I) as an invalid estimate; its
/// batches go to the fusion centre.
std::unique_ptr<estimators::Estimator> make_sensor_only_estimator(const estimators::AgentSetup& setup,
                                                                  double initial_std_m);

/// Builds the estimator of the agent `manifest` describes from the scenario's algorithm settings. For a
/// centralized algorithm (config::runs_in_fusion_centre, config/algorithms.hpp) the agent is a sensor only.
std::unique_ptr<estimators::Estimator> make_agent_estimator(const config::Scenario& scenario,
                                                            const AgentManifest& manifest);

/// The agent `manifest` describes, ready to run: its estimator (make_agent_estimator), its setup and
/// neighbours, and its runtime parameters for incarnation `incarnation` (make_runtime_params). The DDS agent
/// process and the simulator both start their agents with this call.
AgentRuntime make_agent_runtime(const config::Scenario& scenario, const AgentManifest& manifest,
                                int incarnation = 0);

/// The manifest's runtime parameters for incarnation `incarnation` (faults.kill restarts: each starts a
/// new range of sample numbers).
AgentRuntimeParams make_runtime_params(const AgentManifest& manifest, int incarnation = 0);

/// When agent `id`'s free-run timer fires within its tick period, as a fraction of the period
/// (run.tick_phase): spread over the ids by the golden ratio, or 0 for every agent when aligned.
double tick_phase_fraction(const config::Scenario& scenario, AgentId id);

}  // namespace swarmloc::runtime
