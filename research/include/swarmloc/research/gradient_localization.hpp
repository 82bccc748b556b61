#pragma once
// Reproduction experiment of Calafiore et al. Example 2 / Table I (docs/algorithms.md §6.6): DG-BB and its
// baselines on an anchored lattice, run as DgBb estimators over an in-process synchronous bus. No I/O.
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "swarmloc/estimators/gradient/dgbb.hpp"

namespace swarmloc::research {

struct LatticeConfig {
  int side = 10;                ///< side × side nodes on [0, 1]², anchors at the 4 corners
  bool both_diagonals = false;  ///< [E-8]: one diagonal per cell by default
  double initial_std = 0.05;    ///< σ_I: p^(0) = p + N(0, σ_I² I) ([E-8])
  double noise_factor = 0.0;    ///< ν_d of eq. (16); 0 = noiseless
  int runs = 50;
  std::uint64_t seed = 1;
};

/// The lattice problem of one run: truth, anchors, edges with ranges d̄_ij, initial guesses.
struct LatticeProblem {
  std::vector<Vec2> truth;
  estimators::gradient::RangeProblem problem;
};
LatticeProblem make_lattice_problem(const LatticeConfig& config, std::mt19937_64& rng);

struct GradientRun {
  std::int64_t tau_end = 0;        ///< updates until all nodes inactive or τ_max (warm-up included)
  double mean_node_updates = 0.0;  ///< updates per non-anchor node, averaged over those nodes
  std::int64_t rounds = 0;         ///< communication rounds actually simulated (DG-BB: T + 1 per update)
  std::int64_t source_rounds = 0;  ///< the source's count: τ_end·T (DG-BB) or τ_end (others) (§6.2)
  double final_error = 0.0;        ///< Φ = (1/n) Σ_i ‖p_i − p̂_i‖ over all nodes ([E-9])
  bool converged = false;          ///< Φ < 1e−3 ([E-9])
  int safeguard_fires = 0;         ///< [E-4] replacements summed over nodes
  int trust_region_fires = 0;      ///< BB steps shortened by DgBbParams::max_move_fraction, summed over nodes
  std::vector<double> error_trace;  ///< Φ after every update τ (only if requested)
};

/// One run of `params` (its rule selects DG-BB or a baseline) on `lattice` as DgBb agents.
/// `start_ticks` (empty = all 0, the synchronous start): node i is not stepped and publishes nothing before
/// round start_ticks[i] (one tick = one communication round, docs/algorithms.md §6.4 [E-7]); it then
/// publishes its initial STATE, receives its ranges and runs on its own. DgBb's start rule makes an early
/// node wait until every range neighbour has been heard from. Throws std::invalid_argument on a wrong size or
/// a negative tick.
GradientRun run_gradient_agents(const LatticeProblem& lattice, const estimators::gradient::DgBbParams& params,
                                bool record_trace = false, const std::vector<std::int64_t>& start_ticks = {});

struct TableOneRow {
  std::string method;
  double mean_tau_end = 0.0;
  double mean_rounds = 0.0;
  double mean_source_rounds = 0.0;
  double fraction_converged = 0.0;
  double mean_final_error = 0.0;
  double fraction_at_tau_max = 0.0;
  double mean_trust_region_fires = 0.0;  ///< per run, summed over nodes
};

/// Table I of Calafiore et al.: DG-BB (T), local BB ([E-6]), fixed 0.1, fixed 0.01, step length 10/√τ, local
/// BB with eq. (15) as printed (DgBbParams::own_move_curvature), each over config.runs lattices (the same
/// draws for every method). `base` supplies T, η, τ_max, warm-up and the safeguard. With
/// base.max_move_fraction = 0 (the source) two rows follow that are not in the source: DG-BB and local BB
/// with the trust region at 1.
std::vector<TableOneRow> run_table_one(const LatticeConfig& config,
                                       const estimators::gradient::DgBbParams& base);

}  // namespace swarmloc::research
