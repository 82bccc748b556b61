#pragma once
// The centralized algorithms (ekf, lbekf, lbekf_vr, lbekf_i; docs/algorithms.md §2) in process: the fusion
// centre of run/fusion_centre.hpp stepped over a generated world, as the DDS fusion-centre process steps it
// over the batches it receives.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/estimators/centralized/centralized_filter.hpp"
#include "swarmloc/run/fusion_centre.hpp"
#include "swarmloc/sim/simulator.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::sim {

/// `swarmloc sim` for centralized algorithms: builds the world, generates every step's batches with
/// generate_batch, steps the fusion filter and scores every agent. Besides the usual metrics (over
/// non-anchors), record.extra holds "final_total_mse_m2" (all agents, final step) and "total_mse_m2"
/// (per step).
rundir::RunRecord run_centralized_simulation(const config::Scenario& scenario,
                                             const SimOptions& options = {});

// make_sensor_only_estimator: runtime/agent_factory.hpp.

}  // namespace swarmloc::sim
