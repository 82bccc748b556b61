#pragma once
// The centralized algorithms (ekf, lbekf, lbekf_vr, lbekf_i; docs/algorithms.md §2) as a fusion centre: one
// filter holds the whole network state, consumes every agent's measurement batch of a world step and
// yields every agent's estimate (docs/algorithms.md §2.7). The DDS fusion-centre process
// (orchestrator/fusion_center.cpp) and the in-process runner (sim/centralized_runner.hpp) share these
// functions, so both build the same filter from the same world and turn the same batches into the same
// measurements.
#include <memory>
#include <optional>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/estimators/centralized/centralized_filter.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::run {

/// The bandwidth L of the LB-EKF variants (Khan et al. Sec. 5.2: L = 20 for 30 agents in 2-D).
inline constexpr int kCentralizedBandwidth = 20;
/// L in a world of `dimensions` (scalar state entries): in 3-D 30, the same ten agents per band as the
/// plane's.
constexpr int centralized_bandwidth(int dimensions) { return kCentralizedBandwidth * dimensions / 2; }

/// Builds the fusion centre's filter for `world`: x̂(0) = the initial guesses, Σ_0 =
/// algorithm.initial_std_m² · I per agent, σ_p = algorithm.process_noise_std_m², L =
/// centralized_bandwidth(world.dimensions). Labels: lexicographic order of the initial guesses (Khan et al.
/// Alg. 3, [A-5]) for lbekf_vr and lbekf_i, identity for lbekf and ekf. Throws std::invalid_argument if the
/// scenario's algorithm is not centralized.
std::unique_ptr<estimators::centralized::CentralizedFilter> make_fusion_filter(
    const config::Scenario& scenario, const world::World& world);

/// One world step's batches (batches[i] = agent i's, nullptr if it did not arrive) as the fusion
/// centre's input: each anchor's fix is a beacon fix; each undirected edge contributes one range, the
/// one measured by its lower-id endpoint (the higher-id endpoint's if the lower one's batch is
/// missing). Variances come from the scenario (noise.anchor_fix_std_m², noise.range_std_m²), floored
/// at 1e-6 m² so exactly known anchors stay finite.
estimators::centralized::CentralizedMeasurements centralized_measurements(
    const config::Scenario& scenario, const std::vector<const estimators::MeasurementBatch*>& batches);

/// Agent `agent`'s estimate from the filter (mean and 2×2 covariance block; in 3-D also its Altitude).
estimators::Estimate fusion_estimate(const estimators::centralized::CentralizedFilter& filter, AgentId agent);

/// Σ over every agent with an estimate (anchors included) of ‖truth − mean‖²: the total MSE of one
/// run at one step (Khan et al. Fig. 6, docs/algorithms.md §2.8). In 3-D `truth_z` holds the truth's z
/// (World::altitude) and the error is in space; planar worlds pass it empty.
double total_squared_error(const std::vector<Vec2>& truth,
                           const std::vector<std::optional<estimators::Estimate>>& estimates,
                           const std::vector<double>& truth_z = {});

}  // namespace swarmloc::run
