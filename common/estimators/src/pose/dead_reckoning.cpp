// DeadReckoning (estimators/pose/dead_reckoning.hpp).
#include "swarmloc/estimators/pose/dead_reckoning.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "pose/internal.hpp"
#include "swarmloc/core/gaussian.hpp"
#include "swarmloc/estimators/kalman/kernels.hpp"
#include "swarmloc/models/measurement_models.hpp"

namespace swarmloc::estimators {

DeadReckoning::DeadReckoning(const AgentSetup& setup, const KalmanFilterParams& params)
    : setup_(setup), params_(params), x_(Pose::Zero()), P_(Mat3::Identity()) {
  pose_internal::validate(setup, params, "dead_reckoning");
  x_ = pose_internal::initial_pose(setup);
  P_ = pose_internal::initial_covariance(params);
}

Outbox DeadReckoning::initial_outbox() const {
  return pose_internal::publish(x_, P_.topLeftCorner<2, 2>(), 0);
}

StepOutput DeadReckoning::step(const StepInput& input) {
  StepOutput out;
  const pose_internal::Predicted predicted =
      pose_internal::predict_covariance(x_, P_, input.measurements, params_);
  segments_skipped_ += predicted.propagation.segments_skipped;
  x_ = predicted.pose;
  P_ = predicted.P;
  degree_ = pose_internal::batch_degree(input);
  out.outbox = pose_internal::publish(x_, P_.topLeftCorner<2, 2>(), degree_);
  return out;
}

Estimate DeadReckoning::estimate() const { return pose_internal::pose_estimate(x_, P_, true); }

}  // namespace swarmloc::estimators
