#pragma once
// Interlaced EKF at one agent (Gasparri & Pascucci Sec. IV-A specialized to the network, docs/algorithms.md
// §3.5).
#include <string_view>

#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/kalman/kernels.hpp"

namespace swarmloc::estimators {

/// Holds x̂^(i), P^(i), P_0 = initial_std_m²·I. Same inputs, neighbour rules (§3.4) and messages as
/// Ieif; the update is the Kalman form with an M×M innovation covariance and the Joseph form.
/// Same extensions as Ieif (MotionInput, AbsoluteFix).
class Iekf final : public Estimator {
 public:
  Iekf(const AgentSetup& setup, const KalmanFilterParams& params);

  [[nodiscard]] std::string_view name() const override { return "iekf"; }
  [[nodiscard]] Outbox initial_outbox() const override;
  StepOutput step(const StepInput& input) override;
  [[nodiscard]] Estimate estimate() const override;

  [[nodiscard]] const Mat2& covariance() const { return P_; }
  [[nodiscard]] const Vec2& mean() const { return x_; }

 private:
  [[nodiscard]] Outbox published() const;

  AgentSetup setup_;
  KalmanFilterParams params_;
  Mat2 Q_;
  Vec2 x_;
  Mat2 P_;
  int degree_ = 0;
  RangeResidualCheck self_check_;  // docs/algorithms.md §1.6, on the innovations at x̂_{k|k−1}
};

}  // namespace swarmloc::estimators
