#pragma once
// What an agent builds from its scenario and its manifest: the estimator and the scenario-derived
// models it needs (the target's motion, the field's grid). The DDS agent and the simulator call the same
// functions, so lockstep over DDS stays the simulator bit for bit.
#include <memory>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/estimators/consensus/joint_field.hpp"
#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/runtime/manifest.hpp"

namespace swarmloc::sim {

/// The target's model at the world period 1 / run.rate_hz (002 eq. (1)): state dimension 2 (static, F and
/// W empty) or 4 (double integrator: F = [I τI; 0 I], W = q [τ³/3 I, τ²/2 I; τ²/2 I, τ I]).
struct TargetModel {
  int dim = 2;
  MatX F;
  MatX W;
};
TargetModel target_model(const config::Scenario& scenario);

/// The field's grid over the area (world.field_cells_per_side² cells) and the sensing model of its readings.
estimators::consensus::FieldSensor field_sensor(const config::Scenario& scenario);

/// What an agent runs when the algorithm is centralized: nothing. It publishes no inter-agent
/// samples and reports its prior (initial guess, initial_std_m² · I) as an invalid estimate; its
/// batches go to the fusion centre.
std::unique_ptr<estimators::Estimator> make_sensor_only_estimator(const estimators::AgentSetup& setup,
                                                                  double initial_std_m);

/// Builds the estimator of the agent `manifest` describes from the scenario's algorithm settings. For a
/// centralized algorithm (config::runs_in_fusion_centre, config/algorithms.hpp) the agent is a sensor only.
std::unique_ptr<estimators::Estimator> make_agent_estimator(const config::Scenario& scenario,
                                                            const AgentManifest& manifest);

/// The manifest's runtime parameters for incarnation `incarnation` (faults.kill restarts: each starts a
/// new range of sample numbers).
AgentRuntimeParams make_runtime_params(const AgentManifest& manifest, int incarnation = 0);

/// When agent `id`'s free-run timer fires within its tick period, as a fraction of the period
/// (run.tick_phase): spread over the ids by the golden ratio, or 0 for every agent when aligned.
double tick_phase_fraction(const config::Scenario& scenario, AgentId id);

}  // namespace swarmloc::sim
