#pragma once
// The pose EKF at one robot (the model: pose/kernels.hpp).
#include <cstdint>
#include <string_view>

#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/pose/kernels.hpp"

namespace swarmloc::estimators {

/// Pose EKF at one robot: x̂ = (x, y, θ), P (3×3), prior (initial_guess_m, initial_heading_rad) with
/// P_0 = diag(σ_0², σ_0², σ_θ²). Each step: prediction through the batch's odometry, then one stacked
/// update with all range-bearing pairs linearized at the predicted pose (landmarks and interlaced robot
/// peers, optional 2-dof gate). Publishes the position block of the posterior (anchor = false,
/// degree = the batch's neighbour count). Diagnostics: neighbours_used = pairs used (landmarks and
/// robots), neighbours_skipped = pairs dropped, ranges_gated = pairs gated.
class PoseEkf final : public Estimator {
 public:
  PoseEkf(const AgentSetup& setup, const KalmanFilterParams& params);

  [[nodiscard]] std::string_view name() const override { return "pose_ekf"; }
  [[nodiscard]] Outbox initial_outbox() const override;
  StepOutput step(const StepInput& input) override;
  [[nodiscard]] Estimate estimate() const override;

  [[nodiscard]] const Pose& pose() const { return x_; }
  [[nodiscard]] double heading_rad() const { return x_.z(); }
  [[nodiscard]] const Mat3& covariance() const { return P_; }
  /// Odometry segments skipped since construction (propagate_pose).
  [[nodiscard]] std::int64_t odometry_segments_skipped() const { return segments_skipped_; }

 private:
  AgentSetup setup_;
  KalmanFilterParams params_;
  Pose x_;
  Mat3 P_;
  int degree_ = 0;
  std::int64_t segments_skipped_ = 0;
  SightingHistory sightings_;
};

}  // namespace swarmloc::estimators
