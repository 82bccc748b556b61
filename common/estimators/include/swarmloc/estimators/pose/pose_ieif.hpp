#pragma once
// The pose EKF in information form at one robot (the model: pose/kernels.hpp).
#include <cstdint>
#include <string_view>

#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/pose/kernels.hpp"

namespace swarmloc::estimators {

/// The PoseEkf model in information form: Ψ = P⁻¹, ŷ = Ψ x̂ (derived). Prediction in the form that is
/// exact for P ← F P Fᵀ + Q: Ψ_F = F⁻ᵀ Ψ F⁻¹, Ψ_{k|k−1} = (I + Ψ_F Q)⁻¹ Ψ_F (F is unit upper
/// triangular, always invertible). Update: Ψ += Hᵀ R̃⁻¹ H, ŷ += Hᵀ R̃⁻¹ (ν + H x̂_{k|k−1}) with every pair
/// of the step stacked, x̂ = Ψ⁻¹ ŷ. Agrees with PoseEkf up to rounding. Same inputs, rules and messages.
class PoseIeif final : public Estimator {
 public:
  PoseIeif(const AgentSetup& setup, const KalmanFilterParams& params);

  [[nodiscard]] std::string_view name() const override { return "pose_ieif"; }
  [[nodiscard]] Outbox initial_outbox() const override;
  StepOutput step(const StepInput& input) override;
  [[nodiscard]] Estimate estimate() const override;

  [[nodiscard]] const Pose& pose() const { return x_; }
  [[nodiscard]] double heading_rad() const { return x_.z(); }
  [[nodiscard]] const Mat3& information() const { return Psi_; }
  [[nodiscard]] Pose information_vector() const { return Psi_ * x_; }
  /// Ψ⁻¹, or kUndefinedVarianceM2·I if Ψ is not PD.
  [[nodiscard]] Mat3 covariance() const;
  [[nodiscard]] std::int64_t odometry_segments_skipped() const { return segments_skipped_; }

 private:
  AgentSetup setup_;
  KalmanFilterParams params_;
  Pose x_;
  Mat3 Psi_;
  int degree_ = 0;
  std::int64_t segments_skipped_ = 0;
  SightingHistory sightings_;
};

}  // namespace swarmloc::estimators
