#pragma once
// Interlaced Extended Information Filter at one agent (Gasparri & Pascucci, docs/algorithms.md §3.2–3.4).
#include <string_view>

#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/kalman/kernels.hpp"

namespace swarmloc::estimators {

/// Holds x̂^(i) and Ψ^(i) (ŷ = Ψ x̂ is derived). Each step: prediction (eq. (48)), estimation with
/// the ranges whose peer has a state message (eq. (49)), then publishes the predicted pair
/// (x̂_{k+1|k}, Ψ_{k+1|k}⁻¹) ([B-5]). Anchors run no filter: they publish their known position with
/// zero covariance and the anchor flag.
///
/// Extensions beyond §3 (inactive unless the batch carries them): a MotionInput shifts the
/// prediction by v·dt and adds its process covariance to Q; an AbsoluteFix with PD covariance is
/// fused as a linear measurement (H = I₂).
class Ieif final : public Estimator {
 public:
  Ieif(const AgentSetup& setup, const KalmanFilterParams& params);

  [[nodiscard]] std::string_view name() const override { return "ieif"; }
  [[nodiscard]] Outbox initial_outbox() const override;
  StepOutput step(const StepInput& input) override;
  [[nodiscard]] Estimate estimate() const override;

  /// Ψ_{k|k} after the last step (Ψ_0 before the first).
  [[nodiscard]] const Mat2& information() const { return Psi_; }
  /// x̂_{k|k} after the last step.
  [[nodiscard]] const Vec2& mean() const { return x_; }

 private:
  [[nodiscard]] Outbox published() const;

  AgentSetup setup_;
  KalmanFilterParams params_;
  Mat2 Q_;  // process noise per step
  Vec2 x_;
  Mat2 Psi_;
  int degree_ = 0;
  RangeResidualCheck self_check_;  // docs/algorithms.md §1.6, on the innovations at x̂_{k|k−1}
};

}  // namespace swarmloc::estimators
