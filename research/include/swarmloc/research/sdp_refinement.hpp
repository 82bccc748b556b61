#pragma once
// Reproduction experiment of Calafiore et al. Example 3 / Tables II–III (docs/algorithms.md §6.6): random
// geometric graphs, the SDP relaxation as initial guess, DG-BB refinement as DgBb agents over the in-process
// bus, with a synchronous or an asynchronous (random start tick per node, §6.4) start. No I/O.
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "swarmloc/estimators/gradient/dgbb.hpp"
#include "swarmloc/research/gradient_localization.hpp"
#include "swarmloc/research/sdp_relaxation.hpp"

namespace swarmloc::research {

struct GeometricGraphConfig {
  int nodes = 50;              ///< n ([E-8]: not stated in the source; default 50)
  double radius = 0.3;         ///< R: edge iff ‖p_i − p_j‖ < R, positions uniform on [0, 1]²
  int anchors = 3;             ///< n_a, chosen at random among the nodes
  double noise_factor = 0.05;  ///< ν_d of eq. (16): d̄ = |d + ε|, ε ~ N(0, (ν_d d)²)
  int min_unknown_degree = 3;  ///< resample until every non-anchor node has at least this many ranges
  int max_attempts = 10000;    ///< resampling budget (std::runtime_error when exhausted)
};

/// Throws std::invalid_argument naming the offending field.
void validate(const GeometricGraphConfig& config);

/// One Example 3 world: positions, anchors, noisy ranges. Resamples until the graph is connected and every
/// non-anchor node has min_unknown_degree ranges. problem.initial holds the truth for anchors and zeros for
/// the others (the SDP supplies them).
LatticeProblem make_geometric_graph_problem(const GeometricGraphConfig& config, std::mt19937_64& rng);

/// Φ = (1/n) Σ_i ‖p_i − p̂_i‖ over all n nodes, anchors included with error 0 ([E-9]).
double mean_position_error(const std::vector<Vec2>& truth, const std::vector<Vec2>& estimate);

/// Start ticks t_i ~ U{0, …, max_skew} (integer communication rounds, §6.4 [E-7]).
std::vector<std::int64_t> draw_start_ticks(std::size_t nodes, std::int64_t max_skew, std::mt19937_64& rng);

/// The seed of run `run` of an experiment seeded with `seed` (runs are independent: any order, any thread).
std::uint64_t run_seed(std::uint64_t seed, int run);

/// One Example 3 instance with its SDP solution; `world.problem.initial` = the SDP positions when usable.
struct SdpInstance {
  LatticeProblem world;
  SdpRelaxationResult sdp;
  double sdp_error = 0.0;  ///< Φ of the SDP positions (NaN when the SDP failed)
};
SdpInstance make_sdp_instance(const GeometricGraphConfig& config, std::mt19937_64& rng,
                              const SdpRelaxationParams& sdp_params = {});

/// DG-BB parameters of Example 3: T = 20, η_abstol = 1e−15, τ_max = 1e5 (Calafiore et al. Sec. V-C).
estimators::gradient::DgBbParams example3_dgbb_params();

// ---- Table II: Φ of SDP and SDP+DG for n_a × ν_d ----
struct TableTwoConfig {
  int nodes = 50;
  double radius = 0.3;
  std::vector<int> anchors{20, 10, 3};
  std::vector<double> noise_factors{0.05, 0.1, 0.15};
  int runs = 30;
  std::uint64_t seed = 1;
  int threads = 1;
};
struct TableTwoCell {
  int anchors = 0;
  double noise_factor = 0.0;
  int runs = 0;                ///< runs averaged (SDP usable)
  int sdp_failures = 0;        ///< runs whose SDP was not usable (left out of the means)
  int sdp_inaccurate = 0;      ///< runs whose SDP ended with a gap above accept_gap (still used)
  double sdp_error = 0.0;      ///< mean Φ, SDP alone
  double refined_error = 0.0;  ///< mean Φ, SDP + DG-BB
  int refined_better = 0;      ///< runs where SDP+DG < SDP
  double mean_tau_end = 0.0;
  double median_tau_end = 0.0;  ///< robust to the rare runs that stop only at τ_max
  int tau_max_reached = 0;
};
/// Run r of every cell draws its world from run_seed(seed, r) and the cell (same positions across cells
/// of a run when the resampling accepts the first draw). Parallel over runs with `threads` threads.
std::vector<TableTwoCell> run_table_two(const TableTwoConfig& config,
                                        const estimators::gradient::DgBbParams& params);

// ---- Table III: asynchronous start ----
struct TableThreeConfig {
  int nodes = 50;
  double radius = 0.3;
  int anchors = 3;
  double noise_factor = 0.05;
  std::vector<std::int64_t> max_skews{10, 20, 30, 50, 100};  ///< Δt_max in ticks
  int runs = 30;
  std::uint64_t seed = 1;
  int threads = 1;
};
struct TableThreeColumn {
  std::int64_t max_skew = 0;  ///< 0 = the synchronous start
  int runs = 0;
  int sdp_failures = 0;
  double sdp_error = 0.0;
  double refined_error = 0.0;
  double mean_tau_end = 0.0;       ///< max over nodes of the updates, averaged over runs
  double median_tau_end = 0.0;     ///< median over runs (robust to the rare runs that stop only at τ_max)
  double mean_node_updates = 0.0;  ///< updates per non-anchor node, averaged over nodes and runs
  int tau_max_reached = 0;
};
/// First column: synchronous (Δt_max = 0); then one column per max_skews entry, all on the same worlds and
/// SDP solutions (one SDP per run).
std::vector<TableThreeColumn> run_table_three(const TableThreeConfig& config,
                                              const estimators::gradient::DgBbParams& params);

}  // namespace swarmloc::research
