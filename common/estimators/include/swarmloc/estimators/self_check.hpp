#pragma once
// The estimators' self-check (docs/algorithms.md §1.6): a windowed normalized-residual test an agent runs on
// its own range data, so that a filter locked into a wrong (folded, flipped) solution says so instead of
// reporting it confidently. Transport-free: no I/O, clock or RNG.
#include <cstddef>
#include <deque>

namespace swarmloc::estimators {

/// z with P(N(0, 1) > z) = upper_tail, for upper_tail in (0, 1) (Abramowitz & Stegun 26.2.23, absolute
/// error below 4.5e−4). Throws std::invalid_argument outside (0, 1).
double standard_normal_upper_quantile(double upper_tail);

/// q with P(χ²_dof > q) = upper_tail (Wilson–Hilferty: χ²/dof is close to the cube of a normal with mean
/// 1 − 2/(9 dof) and variance 2/(9 dof)). Within 1.2 % of the exact quantile from 10 dof on at the tails
/// used here; above it (conservative) for fewer dof. Throws std::invalid_argument for dof <= 0 or
/// upper_tail outside (0, 1).
double chi_square_upper_quantile(double dof, double upper_tail);

struct SelfCheckParams {
  int window_steps = 10;      ///< steps (with residuals) whose residuals are pooled into one test
  double false_alarm = 1e-4;  ///< the test's size for independent, consistent residuals
};

/// Sums ν²/s over the range residuals of the last `window_steps` steps and compares the sum with the
/// χ² quantile for that many degrees of freedom at `false_alarm`. ν = z − ‖x̂_i − x̂_j‖ is a range's
/// residual against the estimates it was predicted from and s its variance as the filter sees it
/// (σ_r² + uᵀP_i u + uᵀP_j u): a consistent filter gives ν²/s ~ χ²₁, a wrong solution that the
/// covariances do not cover gives a sum far above the quantile.
class RangeResidualCheck {
 public:
  explicit RangeResidualCheck(const SelfCheckParams& params = {});

  /// One range of the current step. Residuals with a variance that is not finite and > 0 are ignored
  /// (nothing to test against), as are non-finite residuals.
  void add(double residual_m, double variance_m2);
  /// Closes the current step; the window keeps the last `window_steps` closed steps that had a residual
  /// (a step without one leaves the window and the verdict as they are).
  void end_step();

  /// Over the closed steps in the window: the sum of ν²/s, its degrees of freedom (residuals), and the
  /// quantile it is compared with (+inf with no residual).
  [[nodiscard]] double statistic() const { return window_sum_; }
  [[nodiscard]] std::size_t residuals() const { return window_count_; }
  [[nodiscard]] double threshold() const;
  /// The verdict: true when the window's sum is above the quantile.
  [[nodiscard]] bool inconsistent() const { return window_count_ > 0 && window_sum_ > threshold(); }

 private:
  struct StepTotals {
    double sum = 0.0;
    std::size_t count = 0;
  };
  SelfCheckParams params_;
  StepTotals open_;                // the step being filled
  std::deque<StepTotals> window_;  // closed steps, oldest first
  double window_sum_ = 0.0;
  std::size_t window_count_ = 0;
};

}  // namespace swarmloc::estimators
