#pragma once
// Reproduction experiments of Calafiore et al. Figs. 4–7 (docs/algorithms.md §6.6 Example 2) on the anchored
// lattices of Table I: Φ against τ (Fig. 4), the share of convergent runs against σ_I (Fig. 5), τ_end against
// T for several network sizes (Fig. 6) and against n with T = 20 (Fig. 7). No I/O; each run's lattice comes
// from (seed, size, σ_I, run), so every method and every T of a cell sees the same draws, and the results
// do not depend on the thread count.
#include <cstdint>
#include <string>
#include <vector>

#include "swarmloc/research/gradient_localization.hpp"

namespace swarmloc::research {

/// Figs. 4–5: local BB (T = 0; eq. (15) as printed, the reading that converges on this lattice, see
/// Table I), DG-BB with `base.consensus_rounds`, and the fixed step 0.1, as Calafiore et al. plots them.
struct ConvergenceFiguresConfig {
  LatticeConfig lattice;  ///< side, diagonals, runs and seed; its initial_std is replaced per cell
  std::vector<double> initial_stds{0.01, 0.02, 0.05, 0.1, 0.15, 0.2};  ///< Fig. 5's x axis ([E-8])
  double traced_initial_std = 0.05;  ///< Fig. 4's σ_I (Table I's, [E-8]); must be in initial_stds
  std::vector<std::int64_t> trace_taus{1, 3, 10, 30, 100, 300, 1000, 3000, 10000, 30000, 100000};
  /// η_abstol of each Fig. 5 table (base.abs_tol is not used); Fig. 4 traces the first. See
  /// ScalingFiguresConfig::abs_tols for why 1e−14 is there.
  std::vector<double> abs_tols{1e-10, 1e-14};
  int threads = 1;
};

struct ConvergenceCurve {
  std::string method;
  /// Mean Φ over the runs after update τ = trace_taus[k]; a run that stopped earlier keeps its final Φ.
  /// NaN if some run diverged before that τ.
  std::vector<double> mean_error;
  /// Updates per run at which Φ grew by more than 10 % (Calafiore et al.: local steps "cause spikes").
  double spikes_per_run = 0.0;
};

struct ConvergenceCell {
  std::string method;
  double initial_std = 0.0;
  double abs_tol = 0.0;
  double fraction_converged = 0.0;  ///< Φ < 1e−3 before τ_max ([E-9])
  double mean_tau_end = 0.0;
};

struct ConvergenceFiguresResult {
  std::vector<ConvergenceCurve> curves;  ///< Fig. 4, σ_I = traced_initial_std
  std::vector<ConvergenceCell> cells;    ///< Fig. 5: per η (outer), σ_I, then method
};

/// `base` supplies η_abstol, τ_max, warm-up and the safeguard; T is base.consensus_rounds.
ConvergenceFiguresResult run_convergence_figures(const ConvergenceFiguresConfig& config,
                                                 const estimators::gradient::DgBbParams& base);

/// Figs. 6–7: DG-BB on side × side lattices for each T.
struct ScalingFiguresConfig {
  LatticeConfig lattice;                 ///< diagonals, σ_I, runs and seed; its side is replaced per cell
  std::vector<int> sides{5, 7, 10, 15};  ///< Fig. 6: n = 25, 49, 100, 225
  std::vector<int> consensus_rounds{1, 2, 5, 10, 20, 50};  ///< Fig. 6's x axis (T)
  std::vector<int> sides_at_t20{20};                       ///< Fig. 7: more sizes, T = 20 only (n = 400)
  /// σ_I in lattice spacings (Calafiore et al. does not say how σ_I scales with n): 0.45 is Table I's 0.05 on
  /// the 10 × 10 lattice, and keeps a guess as likely to fold over on every size. 0: lattice.initial_std.
  double initial_std_per_spacing = 0.45;
  /// η_abstol of each table (base.abs_tol is not used). Table I's 1e−10 stops large lattices early: Φ
  /// plateaus near 3e−3 where the cost is nearly flat (a soft bending mode held by the four corner
  /// anchors), the nodes' moves fall below η and they stop one by one ([E-5]); with 1e−14 they get through.
  std::vector<double> abs_tols{1e-10, 1e-14};
  int threads = 1;
};

struct ScalingCell {
  int nodes = 0;
  int consensus_rounds = 0;
  double abs_tol = 0.0;
  double initial_std = 0.0;             ///< σ_I the cell ran with
  double mean_tau_end = 0.0;            ///< over all runs
  double mean_tau_end_converged = 0.0;  ///< over the runs with Φ < 1e−3 (NaN if none)
  double fraction_converged = 0.0;
  double mean_final_error = 0.0;  ///< Φ
};

/// For each abs_tol: every (side, T) of Fig. 6, then every side of sides_at_t20 with T = 20.
std::vector<ScalingCell> run_scaling_figures(const ScalingFiguresConfig& config,
                                             const estimators::gradient::DgBbParams& base);

}  // namespace swarmloc::research
