#pragma once
// Odometry only, a baseline (the model: pose/kernels.hpp).
#include <cstdint>
#include <string_view>

#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/pose/kernels.hpp"

namespace swarmloc::estimators {

/// Odometry only (a baseline): the PoseEkf prediction, never an update. Publishes like PoseEkf.
class DeadReckoning final : public Estimator {
 public:
  DeadReckoning(const AgentSetup& setup, const KalmanFilterParams& params);

  [[nodiscard]] std::string_view name() const override { return "dead_reckoning"; }
  [[nodiscard]] Outbox initial_outbox() const override;
  StepOutput step(const StepInput& input) override;
  [[nodiscard]] Estimate estimate() const override;

  [[nodiscard]] const Pose& pose() const { return x_; }
  [[nodiscard]] double heading_rad() const { return x_.z(); }
  [[nodiscard]] const Mat3& covariance() const { return P_; }
  [[nodiscard]] std::int64_t odometry_segments_skipped() const { return segments_skipped_; }

 private:
  AgentSetup setup_;
  KalmanFilterParams params_;
  Pose x_;
  Mat3 P_;
  int degree_ = 0;
  std::int64_t segments_skipped_ = 0;
};

}  // namespace swarmloc::estimators
