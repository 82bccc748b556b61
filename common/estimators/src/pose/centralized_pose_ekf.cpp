// CentralizedPoseEkf (estimators/pose/centralized_pose_ekf.hpp).
#include "swarmloc/estimators/pose/centralized_pose_ekf.hpp"

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

CentralizedPoseEkf::CentralizedPoseEkf(const std::vector<AgentSetup>& setups,
                                       const KalmanFilterParams& params)
    : params_(params) {
  const auto n = static_cast<Eigen::Index>(setups.size());
  x_ = VecX::Zero(3 * n);
  P_ = MatX::Zero(3 * n, 3 * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const AgentSetup& setup = setups[static_cast<std::size_t>(i)];
    pose_internal::validate(setup, params, "centralized_pose_ekf");
    if (std::find(ids_.begin(), ids_.end(), setup.id) != ids_.end()) {
      throw std::invalid_argument("centralized_pose_ekf: duplicate agent id " + std::to_string(setup.id));
    }
    ids_.push_back(setup.id);
    sightings_.emplace_back();
    x_.segment<3>(3 * i) = pose_internal::initial_pose(setup);
    P_.block<3, 3>(3 * i, 3 * i) = pose_internal::initial_covariance(params);
  }
}

void CentralizedPoseEkf::add_robot(AgentId id, const Pose& pose, const Mat3& covariance) {
  if (index_of(id))
    throw std::invalid_argument("centralized_pose_ekf: robot " + std::to_string(id) + " is known");
  if (!pose.allFinite() || !covariance.allFinite()) {
    throw std::invalid_argument("centralized_pose_ekf: robot " + std::to_string(id) + ": non-finite pose");
  }
  const Eigen::Index n = x_.size();
  VecX x(n + 3);
  x << x_, pose;
  x(n + 2) = models::wrap_angle(x(n + 2));
  MatX P = MatX::Zero(n + 3, n + 3);
  P.topLeftCorner(n, n) = P_;
  P.bottomRightCorner<3, 3>() = pose_internal::symmetrized3(covariance);
  x_ = std::move(x);
  P_ = std::move(P);
  ids_.push_back(id);
  sightings_.emplace_back();
}

std::optional<int> CentralizedPoseEkf::index_of(AgentId id) const {
  const auto it = std::find(ids_.begin(), ids_.end(), id);
  if (it == ids_.end()) return std::nullopt;
  return static_cast<int>(it - ids_.begin());
}

void CentralizedPoseEkf::predict(const std::vector<const MeasurementBatch*>& batches) {
  const int n = num_robots();
  // Prediction, robot by robot: the joint F and Q are block diagonal.
  for (int i = 0; i < n; ++i) {
    const Pose x_i = x_.segment<3>(3 * i);
    PosePropagation prop = propagate_pose(x_i, batches[static_cast<std::size_t>(i)], params_);
    MatX rows = prop.F * P_.middleRows(3 * i, 3);
    if (!prop.pose.allFinite() || !rows.allFinite() ||
        !(rows.middleCols<3>(3 * i) * prop.F.transpose()).allFinite()) {
      prop.segments_skipped += prop.segments_used;  // no-odometry fallback, as the per-agent filters
      prop.segments_used = 0;
      prop.pose = x_i;
      prop.F = Mat3::Identity();
      prop.Q = position_random_walk(params_);
      rows = P_.middleRows(3 * i, 3);
    }
    segments_skipped_ += prop.segments_skipped;
    P_.middleRows(3 * i, 3) = rows;
    P_.middleCols(3 * i, 3) = P_.middleCols(3 * i, 3) * prop.F.transpose();
    P_.block<3, 3>(3 * i, 3 * i) += prop.Q;
    x_.segment<3>(3 * i) = prop.pose;
  }
  P_ = 0.5 * (P_ + P_.transpose());
}

RangeBearingRows CentralizedPoseEkf::joint_rows(const std::vector<const MeasurementBatch*>& batches) {
  const int n = num_robots();
  RangeBearingRows rows;
  std::vector<Eigen::Matrix<double, 2, Eigen::Dynamic>> blocks;
  std::vector<Vec2> innovations;
  for (int i = 0; i < n; ++i) {
    const MeasurementBatch* batch = batches[static_cast<std::size_t>(i)];
    if (batch == nullptr) continue;
    const Pose x_i = x_.segment<3>(3 * i);
    const OdometryInput* odometry = batch->odometry ? &*batch->odometry : nullptr;
    for (const RangeBearingMeasurement& m : batch->range_bearings) {
      const std::optional<Mat2> R = pose_internal::measurement_noise(m);
      if (!R) {
        ++diagnostics_.neighbours_skipped;
        continue;
      }
      Eigen::Matrix<double, 2, Eigen::Dynamic> H = Eigen::Matrix<double, 2, Eigen::Dynamic>::Zero(2, 3 * n);
      Mat2 noise = *R;
      const RewoundPose at = rewind_pose(x_i, odometry, m.age_s);
      std::optional<models::RangeBearingEvaluation> h;
      if (m.landmark) {
        const std::optional<Mat2> cov = pose_internal::landmark_covariance(m);
        if (cov) h = models::range_bearing(at.pose, m.landmark_m);
        if (!cov || !h) {
          ++diagnostics_.neighbours_skipped;
          continue;
        }
        noise += h->d_target * *cov * h->d_target.transpose();
      } else {
        const std::optional<int> j = index_of(m.peer);
        if (j && *j != i) h = models::range_bearing(at.pose, x_.segment<2>(3 * *j));
        if (!j || *j == i || !h) {
          ++diagnostics_.neighbours_skipped;
          continue;
        }
        H.middleCols<2>(3 * *j) = h->d_target;  // the peer's position is in the state
      }
      const Vec2 factor = sightings_[static_cast<std::size_t>(i)].inflation(m.peer, m.landmark, m.landmark_m,
                                                                            batch->world_time_s, params_);
      noise(0, 0) += (factor.x() - 1.0) * (*R)(0, 0);
      noise(1, 1) += (factor.y() - 1.0) * (*R)(1, 1);
      noise = core::symmetrized(noise);
      if (!pose_internal::invertible_noise(noise)) {
        ++diagnostics_.neighbours_skipped;
        continue;
      }
      H.middleCols<3>(3 * i) = h->d_pose * at.d_end;
      blocks.push_back(H);
      innovations.emplace_back(m.range_m - h->value.x(),
                               models::bearing_residual(m.bearing_rad, h->value.y()));
      rows.noise.push_back(noise);
    }
  }
  rows.H = MatX::Zero(2 * rows.pairs(), 3 * n);
  rows.innovation = VecX::Zero(2 * rows.pairs());
  for (int m = 0; m < rows.pairs(); ++m) {
    rows.H.middleRows(2 * m, 2) = blocks[static_cast<std::size_t>(m)];
    rows.innovation.segment<2>(2 * m) = innovations[static_cast<std::size_t>(m)];
  }
  return rows;
}

void CentralizedPoseEkf::step(const std::vector<const MeasurementBatch*>& batches) {
  if (batches.size() != ids_.size()) {
    throw std::invalid_argument("centralized_pose_ekf: " + std::to_string(batches.size()) + " batches for " +
                                std::to_string(ids_.size()) + " robots");
  }
  diagnostics_ = StepDiagnostics{};
  predict(batches);
  RangeBearingRows rows = joint_rows(batches);
  diagnostics_.ranges_gated = gate_range_bearings(rows, P_, params_.range_bearing_gate_chi2);
  diagnostics_.neighbours_used = rows.pairs();
  if (rows.pairs() > 0) {
    if (const auto update = stacked_kalman_update(x_, P_, rows)) {
      x_ = update->mean;
      P_ = update->covariance;
      diagnostics_.updated = true;
    }
  }
}

Estimate CentralizedPoseEkf::estimate(AgentId id) const {
  Estimate estimate;
  const std::optional<int> i = index_of(id);
  if (!i) return estimate;
  estimate.mean_m = x_.segment<2>(3 * *i);
  estimate.covariance = core::symmetrized(P_.block<2, 2>(3 * *i, 3 * *i));
  estimate.valid = true;
  estimate.heading =
      pose_internal::pose_heading_estimate(x_.segment<3>(3 * *i), P_.block<3, 3>(3 * *i, 3 * *i));
  return estimate;
}

Mat3 CentralizedPoseEkf::pose_covariance(AgentId id) const {
  const std::optional<int> i = index_of(id);
  if (!i) throw std::invalid_argument("centralized_pose_ekf: unknown agent id " + std::to_string(id));
  return P_.block<3, 3>(3 * *i, 3 * *i);
}

Pose CentralizedPoseEkf::pose(AgentId id) const {
  const std::optional<int> i = index_of(id);
  if (!i) throw std::invalid_argument("centralized_pose_ekf: unknown agent id " + std::to_string(id));
  return x_.segment<3>(3 * *i);
}

}  // namespace swarmloc::estimators
