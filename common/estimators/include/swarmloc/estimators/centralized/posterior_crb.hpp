#pragma once
// Posterior Cramér–Rao bound recursion for the centralized problem (docs/algorithms.md §1.3, "Dynamic bound
// for A"): J_0 = Σ_0⁻¹ + I(x(0)), J_k = (J_{k−1}⁻¹ + σ_p I)⁻¹ + I(x(k)), with I(x) = Σ_m H_mᵀR_m⁻¹H_m
// evaluated at the true positions. Dense, O(n³) per step.
#include <vector>

#include "swarmloc/core/types.hpp"
#include "swarmloc/estimators/centralized/centralized_filter.hpp"

namespace swarmloc::estimators::centralized {

class PosteriorCrb {
 public:
  /// initial_cov: Σ_0 blocks (one per agent); process_var: σ_p (a variance).
  PosteriorCrb(const std::vector<Mat2>& initial_cov, double process_var);

  /// Adds step k. `pattern` supplies which beacons and edges measured and their variances (the
  /// measured values are ignored); `true_positions` is x(k), 2N.
  void step(const CentralizedMeasurements& pattern, const VecX& true_positions);

  /// tr(J_k⁻¹): lower bound on the total MSE(k).
  [[nodiscard]] double total_bound() const { return bound_.trace(); }
  /// [J_k⁻¹]_ii: tr of it bounds MSE_i(k).
  [[nodiscard]] Mat2 agent_bound(int agent) const { return bound_.block<2, 2>(2 * agent, 2 * agent); }
  [[nodiscard]] const MatX& information() const { return information_; }
  [[nodiscard]] const MatX& bound() const { return bound_; }

 private:
  std::vector<Mat2> initial_cov_;
  double process_var_;
  int steps_done_ = 0;
  MatX information_;  ///< J_k
  MatX bound_;        ///< J_k⁻¹
};

}  // namespace swarmloc::estimators::centralized
