#pragma once
// Helpers of the pose filters (src/pose/*.cpp) that are not part of the kernels estimators/pose/kernels.hpp
// exposes.
#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include "swarmloc/core/gaussian.hpp"
#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/kalman/kernels.hpp"
#include "swarmloc/estimators/pose/kernels.hpp"
#include "swarmloc/models/measurement_models.hpp"

namespace swarmloc::estimators::pose_internal {

inline bool finite_positive(double value) { return std::isfinite(value) && value > 0.0; }

/// R = diag(σ_r², σ_β²) if the pair's values and stds are usable.
inline std::optional<Mat2> measurement_noise(const RangeBearingMeasurement& m) {
  if (!std::isfinite(m.range_m) || !(m.range_m >= 0.0) || !std::isfinite(m.bearing_rad)) return std::nullopt;
  if (!std::isfinite(m.age_s) || !(m.age_s >= 0.0)) return std::nullopt;
  if (!finite_positive(m.range_std_m) || !finite_positive(m.bearing_std_rad)) return std::nullopt;
  Mat2 R = Mat2::Zero();
  R(0, 0) = m.range_std_m * m.range_std_m;
  R(1, 1) = m.bearing_std_rad * m.bearing_std_rad;
  if (!R.allFinite() || !(R(0, 0) > 0.0) || !(R(1, 1) > 0.0)) return std::nullopt;  // σ² under/overflow
  return R;
}

/// The landmark's covariance if its position is finite and the covariance finite and PSD.
inline std::optional<Mat2> landmark_covariance(const RangeBearingMeasurement& m) {
  if (!m.landmark_m.allFinite() || !m.landmark_cov.allFinite()) return std::nullopt;
  const Mat2 cov = core::symmetrized(m.landmark_cov);
  if (!core::is_symmetric_psd(cov)) return std::nullopt;
  return cov;
}

/// True if `m` is finite, symmetric and PD (LLT succeeds): R̃ blocks must be invertible.
inline bool invertible_noise(const Mat2& m) {
  if (!m.allFinite()) return false;
  const Eigen::LLT<Mat2> llt(m);
  return llt.info() == Eigen::Success && m(0, 0) > 0.0 && m.determinant() > 0.0;
}

inline void wrap_headings(VecX& x) {
  for (Eigen::Index k = 2; k < x.size(); k += 3) x(k) = models::wrap_angle(x(k));
}

inline void validate(const AgentSetup& setup, const KalmanFilterParams& params, const std::string& name) {
  if (!finite_positive(params.initial_std_m) || !finite_positive(params.initial_heading_std_rad)) {
    throw std::invalid_argument(name + ": initial_std_m and initial_heading_std_rad must be > 0");
  }
  if (!(params.process_noise_std_m >= 0.0) || !std::isfinite(params.process_noise_std_m)) {
    throw std::invalid_argument(name + ": process_noise_std_m must be >= 0");
  }
  if (!setup.initial_guess_m.allFinite() || !std::isfinite(setup.initial_heading_rad)) {
    throw std::invalid_argument(name + ": initial pose is not finite");
  }
}

inline Pose initial_pose(const AgentSetup& setup) {
  return Pose(setup.initial_guess_m.x(), setup.initial_guess_m.y(),
              models::wrap_angle(setup.initial_heading_rad));
}

inline Mat3 initial_covariance(const KalmanFilterParams& params) {
  const double s = params.initial_std_m;
  const double h = params.initial_heading_std_rad;
  return Eigen::Vector3d(s * s, s * s, h * h).asDiagonal();
}

inline Mat3 symmetrized3(const Mat3& m) { return 0.5 * (m + m.transpose()); }

inline int batch_degree(const StepInput& input) {
  if (input.measurements == nullptr) return 0;
  return static_cast<int>(std::min<std::size_t>(input.measurements->neighbours.size(),
                                                std::numeric_limits<std::uint16_t>::max()));
}

/// The batch's odometry (nullptr without one): the sightings' poses are rewound through it.
inline const OdometryInput* batch_odometry(const StepInput& input) {
  return input.measurements != nullptr && input.measurements->odometry ? &*input.measurements->odometry
                                                                       : nullptr;
}

/// The batch's world time (NaN without a batch: nothing to weigh).
inline double batch_time_s(const StepInput& input) {
  return input.measurements != nullptr ? input.measurements->world_time_s
                                       : std::numeric_limits<double>::quiet_NaN();
}

inline Outbox publish(const Pose& x, const Mat2& position_cov, int degree) {
  StateMessage state;
  state.mean_m = x.head<2>();
  state.covariance = position_cov.allFinite() ? core::symmetrized(position_cov)
                                              : Mat2(kUndefinedVarianceM2 * Mat2::Identity());
  state.anchor = false;
  state.active = true;
  state.degree = static_cast<std::uint16_t>(degree);
  Outbox outbox;
  outbox.state = state;
  return outbox;
}

/// Prediction of a per-agent filter in covariance form; falls back to the no-odometry model (and counts
/// the segments as skipped) if the odometry would make the state non-finite (e.g. absurd speeds).
struct Predicted {
  Pose pose;
  Mat3 P;
  PosePropagation propagation;
};

inline Predicted predict_covariance(const Pose& x, const Mat3& P, const MeasurementBatch* batch,
                                    const KalmanFilterParams& params) {
  Predicted out;
  out.propagation = propagate_pose(x, batch, params);
  const PosePropagation& prop = out.propagation;
  out.pose = prop.pose;
  out.P = symmetrized3(prop.F * P * prop.F.transpose() + prop.Q);
  if (!out.pose.allFinite() || !out.P.allFinite()) {
    out.propagation.segments_skipped += out.propagation.segments_used;
    out.propagation.segments_used = 0;
    out.propagation.F = Mat3::Identity();
    out.propagation.Q = position_random_walk(params);
    out.propagation.pose = x;
    out.pose = x;
    out.P = symmetrized3(P + out.propagation.Q);
  }
  return out;
}

/// The heading part of a pose estimate (x, y, θ) with covariance P (Estimate::heading).
inline HeadingEstimate pose_heading_estimate(const Pose& x, const Mat3& P) {
  return HeadingEstimate{x.z(), P(2, 2), Vec2(P(0, 2), P(1, 2))};
}

/// The estimate of a pose (x, y, θ) with covariance P: position, its covariance block and the heading.
inline Estimate pose_estimate(const Pose& x, const Mat3& P, bool valid) {
  Estimate estimate;
  estimate.mean_m = x.head<2>();
  estimate.covariance = P.topLeftCorner<2, 2>();
  estimate.valid = valid;
  estimate.heading = pose_heading_estimate(x, P);
  return estimate;
}

}  // namespace swarmloc::estimators::pose_internal
