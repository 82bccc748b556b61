// PoseIeif (estimators/pose/pose_ieif.hpp).
#include "swarmloc/estimators/pose/pose_ieif.hpp"

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

PoseIeif::PoseIeif(const AgentSetup& setup, const KalmanFilterParams& params)
    : setup_(setup), params_(params), x_(Pose::Zero()), Psi_(Mat3::Identity()) {
  pose_internal::validate(setup, params, "pose_ieif");
  x_ = pose_internal::initial_pose(setup);
  Psi_ = pose_internal::initial_covariance(params).inverse();  // diagonal, positive
}

Mat3 PoseIeif::covariance() const {
  const Eigen::LLT<Mat3> llt(Psi_);
  if (!Psi_.allFinite() || llt.info() != Eigen::Success) return kUndefinedVarianceM2 * Mat3::Identity();
  return pose_internal::symmetrized3(llt.solve(Mat3::Identity()));
}

Outbox PoseIeif::initial_outbox() const {
  return pose_internal::publish(x_, covariance().topLeftCorner<2, 2>(), 0);
}

StepOutput PoseIeif::step(const StepInput& input) {
  StepOutput out;
  PosePropagation prop = propagate_pose(x_, input.measurements, params_);
  // Ψ_F = F⁻ᵀ Ψ F⁻¹, Ψ_{k|k−1} = (I + Ψ_F Q)⁻¹ Ψ_F: the information of F P Fᵀ + Q (valid for singular Ψ).
  const auto predict = [&](const PosePropagation& p) {
    const Mat3 F_inv = p.F.inverse();
    const Mat3 Psi_F = F_inv.transpose() * Psi_ * F_inv;
    return pose_internal::symmetrized3((Mat3::Identity() + Psi_F * p.Q).partialPivLu().solve(Psi_F));
  };
  Mat3 Psi_pred = predict(prop);
  if (!prop.pose.allFinite() || !Psi_pred.allFinite()) {  // as predict_covariance: no-odometry fallback
    prop.segments_skipped += prop.segments_used;
    prop.segments_used = 0;
    prop.pose = x_;
    prop.F = Mat3::Identity();
    prop.Q = position_random_walk(params_);
    Psi_pred = predict(prop);
  }
  segments_skipped_ += prop.segments_skipped;
  const Pose x_pred = prop.pose;

  RangeBearingSelection selection = collect_range_bearings(input, setup_.id, params_);
  weigh_correlated_sightings(selection.targets, sightings_, pose_internal::batch_time_s(input), params_);
  RangeBearingRows rows =
      linearize_range_bearings(x_pred, selection.targets, pose_internal::batch_odometry(input));
  const Eigen::LLT<Mat3> llt_pred(Psi_pred);
  if (params_.range_bearing_gate_chi2 > 0.0 && llt_pred.info() == Eigen::Success) {
    out.diagnostics.ranges_gated =
        gate_range_bearings(rows, MatX(llt_pred.solve(Mat3::Identity())), params_.range_bearing_gate_chi2);
  }
  out.diagnostics.neighbours_used = rows.pairs();
  out.diagnostics.neighbours_skipped = selection.skipped + rows.skipped;

  x_ = x_pred;
  Psi_ = Psi_pred;
  if (rows.pairs() > 0) {
    // Ψ_{k|k} = Ψ_{k|k−1} + Hᵀ R̃⁻¹ H, ŷ_{k|k} = Ψ_{k|k−1} x̂ + Hᵀ R̃⁻¹ (ν + H x̂) = Ψ_{k|k−1} x̂ + A x̂ + b.
    const RowInformation info = range_bearing_information(rows);
    const Mat3 A = info.A;
    const Mat3 Psi_post = pose_internal::symmetrized3(Psi_pred + A);
    const Pose y_post = Psi_pred * x_pred + A * x_pred + Pose(info.b);
    const Eigen::LLT<Mat3> llt(Psi_post);
    if (llt.info() == Eigen::Success) {
      Pose x_post = llt.solve(y_post);
      x_post.z() = models::wrap_angle(x_post.z());
      if (x_post.allFinite() && Psi_post.allFinite()) {
        x_ = x_post;
        Psi_ = Psi_post;
        out.diagnostics.updated = true;
      }
    }
  }
  degree_ = pose_internal::batch_degree(input);
  out.outbox = pose_internal::publish(x_, covariance().topLeftCorner<2, 2>(), degree_);
  return out;
}

Estimate PoseIeif::estimate() const {
  const Eigen::LLT<Mat3> llt(Psi_);
  return pose_internal::pose_estimate(x_, covariance(), Psi_.allFinite() && llt.info() == Eigen::Success);
}

}  // namespace swarmloc::estimators
