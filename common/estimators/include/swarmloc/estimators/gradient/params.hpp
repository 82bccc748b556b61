#pragma once
// The gradient family's parameters (Calafiore et al., docs/algorithms.md §6): DG-BB and its baselines.
#include <cstdint>
#include <limits>

#include "swarmloc/estimators/consensus/metropolis.hpp"

namespace swarmloc::estimators::gradient {

enum class StepRule {
  kConsensusBb,  ///< DG-BB: α_i = ρ_i(T)/ψ_i(T) after T consensus rounds (Calafiore et al. eq. (12))
  kLocalBb,      ///< α_i = ‖Δp_i‖²/(Δp_iᵀΔD_i) (Calafiore et al. eq. (15), [E-6])
  kFixed,        ///< α = fixed_step
  kStepLength,   ///< α = k/‖D_i‖ with k = step_length·{1, 1/τ, 1/√τ}
};

enum class StepLengthSchedule { kConstant, kOverTau, kOverSqrtTau };

struct DgBbParams {
  StepRule rule = StepRule::kConsensusBb;
  int consensus_rounds = 20;          ///< T
  int warmup_updates = 1;             ///< τ_wup
  double warmup_step = 1e-6;          ///< α̃
  double abs_tol = 1e-10;             ///< η_abstol
  std::int64_t max_updates = 100000;  ///< τ_max
  double fixed_step = 0.1;            ///< ᾱ for kFixed
  double step_length = 10.0;          ///< k̄ for kStepLength
  StepLengthSchedule schedule = StepLengthSchedule::kOverSqrtTau;
  bool curvature_safeguard = true;  ///< [E-4]
  /// Upper bound on any BB step (not in the source; default ∞ = off). Local BB diverges without it on the
  /// Example 2 lattice: a near-zero positive ψ_i gives a huge α_i and the quartic cost explodes.
  double max_step = std::numeric_limits<double>::infinity();
  /// BB trust region (not in the source; 0 = off): one BB update moves a node at most this fraction of its
  /// shortest measured range. A lost or stale consensus value can leave ψ_i(T) near zero but positive; the
  /// resulting huge α throws the node across its neighbours into a fold-over local minimum of the quartic
  /// cost, which no later step undoes. A node never needs to jump past half its nearest neighbour.
  double max_move_fraction = 0.0;
  double grad_scale = 1.0;  ///< [E-1]: 1 = D_i = ½∇_i f, 2 = ∇_i f
  /// kLocalBb: eq. (15) as printed, ∇_i f(p_i^(τ)) − ∇_i f(p_i^(τ−1)), both with the neighbours' newest
  /// positions, so ΔD_i is the change that node i's own move made (off: [E-6], the change of ∇_i f(p),
  /// neighbours' moves included).
  bool own_move_curvature = false;
  consensus::MetropolisRule weights = consensus::MetropolisRule::kPlusOne;
};

}  // namespace swarmloc::estimators::gradient
