// PoseEkf (estimators/pose/pose_ekf.hpp).
#include "swarmloc/estimators/pose/pose_ekf.hpp"

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

PoseEkf::PoseEkf(const AgentSetup& setup, const KalmanFilterParams& params)
    : setup_(setup), params_(params), x_(Pose::Zero()), P_(Mat3::Identity()) {
  pose_internal::validate(setup, params, "pose_ekf");
  x_ = pose_internal::initial_pose(setup);
  P_ = pose_internal::initial_covariance(params);
}

Outbox PoseEkf::initial_outbox() const { return pose_internal::publish(x_, P_.topLeftCorner<2, 2>(), 0); }

StepOutput PoseEkf::step(const StepInput& input) {
  StepOutput out;
  const pose_internal::Predicted predicted =
      pose_internal::predict_covariance(x_, P_, input.measurements, params_);
  segments_skipped_ += predicted.propagation.segments_skipped;

  RangeBearingSelection selection = collect_range_bearings(input, setup_.id, params_);
  weigh_correlated_sightings(selection.targets, sightings_, pose_internal::batch_time_s(input), params_);
  RangeBearingRows rows =
      linearize_range_bearings(predicted.pose, selection.targets, pose_internal::batch_odometry(input));
  out.diagnostics.ranges_gated = gate_range_bearings(rows, predicted.P, params_.range_bearing_gate_chi2);
  out.diagnostics.neighbours_used = rows.pairs();
  out.diagnostics.neighbours_skipped = selection.skipped + rows.skipped;

  x_ = predicted.pose;
  P_ = predicted.P;
  if (rows.pairs() > 0) {
    if (const auto update = stacked_kalman_update(predicted.pose, predicted.P, rows)) {
      x_ = update->mean;
      P_ = update->covariance;
      out.diagnostics.updated = true;
    }
  }
  degree_ = pose_internal::batch_degree(input);
  out.outbox = pose_internal::publish(x_, P_.topLeftCorner<2, 2>(), degree_);
  return out;
}

Estimate PoseEkf::estimate() const { return pose_internal::pose_estimate(x_, P_, true); }

}  // namespace swarmloc::estimators
