#include "swarmloc/estimators/pose_filters.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "swarmloc/core/gaussian.hpp"
#include "swarmloc/estimators/kalman_family.hpp"
#include "swarmloc/models/measurement_models.hpp"

namespace swarmloc::estimators {
namespace {

bool finite_positive(double value) { return std::isfinite(value) && value > 0.0; }

/// R = diag(σ_r², σ_β²) if the pair's values and stds are usable.
std::optional<Mat2> measurement_noise(const RangeBearingMeasurement& m) {
  if (!std::isfinite(m.range_m) || !(m.range_m >= 0.0) || !std::isfinite(m.bearing_rad)) return std::nullopt;
  if (!finite_positive(m.range_std_m) || !finite_positive(m.bearing_std_rad)) return std::nullopt;
  Mat2 R = Mat2::Zero();
  R(0, 0) = m.range_std_m * m.range_std_m;
  R(1, 1) = m.bearing_std_rad * m.bearing_std_rad;
  if (!R.allFinite() || !(R(0, 0) > 0.0) || !(R(1, 1) > 0.0)) return std::nullopt;  // σ² under/overflow
  return R;
}

/// The landmark's covariance if its position is finite and the covariance finite and PSD.
std::optional<Mat2> landmark_covariance(const RangeBearingMeasurement& m) {
  if (!m.landmark_m.allFinite() || !m.landmark_cov.allFinite()) return std::nullopt;
  const Mat2 cov = core::symmetrized(m.landmark_cov);
  if (!core::is_symmetric_psd(cov)) return std::nullopt;
  return cov;
}

/// True if `m` is finite, symmetric and PD (LLT succeeds): R̃ blocks must be invertible.
bool invertible_noise(const Mat2& m) {
  if (!m.allFinite()) return false;
  const Eigen::LLT<Mat2> llt(m);
  return llt.info() == Eigen::Success && m(0, 0) > 0.0 && m.determinant() > 0.0;
}

void wrap_headings(VecX& x) {
  for (Eigen::Index k = 2; k < x.size(); k += 3) x(k) = models::wrap_angle(x(k));
}

void validate(const AgentSetup& setup, const KalmanFamilyParams& params, const std::string& name) {
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

Pose initial_pose(const AgentSetup& setup) {
  return Pose(setup.initial_guess_m.x(), setup.initial_guess_m.y(),
              models::wrap_angle(setup.initial_heading_rad));
}

Mat3 initial_covariance(const KalmanFamilyParams& params) {
  const double s = params.initial_std_m;
  const double h = params.initial_heading_std_rad;
  return Eigen::Vector3d(s * s, s * s, h * h).asDiagonal();
}

Mat3 symmetrized3(const Mat3& m) { return 0.5 * (m + m.transpose()); }

int batch_degree(const StepInput& input) {
  if (input.measurements == nullptr) return 0;
  return static_cast<int>(std::min<std::size_t>(input.measurements->neighbours.size(),
                                                std::numeric_limits<std::uint16_t>::max()));
}

Outbox publish(const Pose& x, const Mat2& position_cov, int degree) {
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

Predicted predict_covariance(const Pose& x, const Mat3& P, const MeasurementBatch* batch,
                             const KalmanFamilyParams& params) {
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
HeadingEstimate pose_heading_estimate(const Pose& x, const Mat3& P) {
  return HeadingEstimate{x.z(), P(2, 2), Vec2(P(0, 2), P(1, 2))};
}

}  // namespace

// ---- Kernels ----

Mat3 position_random_walk(const KalmanFamilyParams& params) {
  const double q = params.process_noise_std_m * params.process_noise_std_m;
  return Eigen::Vector3d(q, q, 0.0).asDiagonal();
}

PosePropagation propagate_pose(const Pose& pose, const MeasurementBatch* batch,
                               const KalmanFamilyParams& params) {
  PosePropagation out;
  out.pose = pose;
  const OdometryInput* odometry = (batch != nullptr && batch->odometry) ? &*batch->odometry : nullptr;
  bool random_walk = odometry == nullptr;
  if (odometry != nullptr) {
    const bool noise_ok = std::isfinite(odometry->v_std) && odometry->v_std >= 0.0 &&
                          std::isfinite(odometry->omega_std) && odometry->omega_std >= 0.0;
    if (!noise_ok) {
      out.segments_skipped = std::max<int>(1, static_cast<int>(odometry->segments.size()));
      random_walk = true;
    } else {
      for (const OdometrySegment& segment : odometry->segments) {
        const double d = segment.v_mps * segment.dt_s;
        const double a = segment.omega_radps * segment.dt_s;
        const bool usable =
            std::isfinite(segment.dt_s) && segment.dt_s >= 0.0 && std::isfinite(d) && std::isfinite(a);
        if (!usable) {
          ++out.segments_skipped;
          continue;
        }
        const models::UnicycleStep step = models::unicycle_step(out.pose, d, a);
        const Mat3 Q =
            models::unicycle_process_noise(step.G, odometry->v_std, odometry->omega_std, segment.dt_s);
        if (!step.pose.allFinite() || !step.F.allFinite() || !Q.allFinite()) {
          ++out.segments_skipped;
          continue;
        }
        // Composition: P₂ = F₂(F₁ P F₁ᵀ + Q₁)F₂ᵀ + Q₂ = (F₂F₁) P (F₂F₁)ᵀ + (F₂ Q₁ F₂ᵀ + Q₂).
        out.pose = step.pose;
        out.Q = symmetrized3(step.F * out.Q * step.F.transpose() + Q);
        out.F = step.F * out.F;
        ++out.segments_used;
      }
      random_walk = out.segments_skipped > 0;
    }
  }
  if (random_walk) out.Q += position_random_walk(params);
  return out;
}

std::int64_t pose_message_age_steps(std::int64_t local_step, std::int64_t sender_step) {
  return std::max<std::int64_t>(0, local_step - sender_step);
}

RangeBearingSelection collect_range_bearings(const StepInput& input, AgentId self,
                                             const KalmanFamilyParams& params) {
  RangeBearingSelection selection;
  if (input.measurements == nullptr) return selection;
  std::unordered_map<AgentId, const Received<StateMessage>*> newest;
  if (input.inbox != nullptr) {
    for (const auto& received : input.inbox->states) {
      if (received.sender == self) continue;
      auto [it, inserted] = newest.try_emplace(received.sender, &received);
      if (!inserted && received.sender_step > it->second->sender_step) it->second = &received;
    }
  }
  const Mat3 Q_pos = position_random_walk(params);
  for (const RangeBearingMeasurement& m : input.measurements->range_bearings) {
    const std::optional<Mat2> R = measurement_noise(m);
    if (!R) {
      ++selection.skipped;
      continue;
    }
    RangeBearingTarget target;
    target.peer = m.peer;
    target.landmark = m.landmark;
    target.measured = Vec2(m.range_m, m.bearing_rad);
    target.noise = *R;
    if (m.landmark) {
      const std::optional<Mat2> cov = landmark_covariance(m);
      if (!cov) {
        ++selection.skipped;
        continue;
      }
      target.target_m = m.landmark_m;
      target.target_cov = *cov;
    } else {
      const auto found = newest.find(m.peer);
      if (m.peer == self || found == newest.end()) {
        ++selection.skipped;  // no state message of this peer
        continue;
      }
      const Received<StateMessage>& received = *found->second;
      Mat2 P_j = core::symmetrized(received.message.covariance);
      if (params.inflate_stale && !received.message.anchor) {
        P_j += static_cast<double>(pose_message_age_steps(input.local_step, received.sender_step)) *
               Q_pos.topLeftCorner<2, 2>();
      }
      const bool usable = received.message.mean_m.allFinite() && P_j.allFinite() &&
                          core::is_symmetric_psd(P_j) && P_j.trace() <= params.max_neighbour_variance_m2;
      if (!usable) {
        ++selection.skipped;
        continue;
      }
      target.target_m = received.message.mean_m;
      target.target_cov = P_j;
    }
    selection.targets.push_back(target);
  }
  return selection;
}

RangeBearingRows linearize_range_bearings(const Pose& pose, const std::vector<RangeBearingTarget>& targets) {
  RangeBearingRows rows;
  rows.H = MatX::Zero(2 * static_cast<Eigen::Index>(targets.size()), 3);
  rows.innovation = VecX::Zero(rows.H.rows());
  for (const RangeBearingTarget& target : targets) {
    const auto h = models::range_bearing(pose, target.target_m);
    if (!h) {
      ++rows.skipped;  // target at the robot: no direction
      continue;
    }
    // Interlacing: the target's uncertainty enters as noise, R̃ = R + H_t Σ_t H_tᵀ.
    const Mat2 noise =
        core::symmetrized(target.noise + h->d_target * target.target_cov * h->d_target.transpose());
    if (!invertible_noise(noise)) {
      ++rows.skipped;
      continue;
    }
    const Eigen::Index r = 2 * rows.pairs();
    rows.H.block<2, 3>(r, 0) = h->d_pose;
    rows.innovation(r) = target.measured.x() - h->value.x();
    rows.innovation(r + 1) = models::bearing_residual(target.measured.y(), h->value.y());
    rows.noise.push_back(noise);
  }
  rows.H.conservativeResize(2 * rows.pairs(), 3);
  rows.innovation.conservativeResize(2 * rows.pairs());
  return rows;
}

int gate_range_bearings(RangeBearingRows& rows, const MatX& P_pred, double chi2_gate) {
  if (!(chi2_gate > 0.0) || !P_pred.allFinite() || rows.pairs() == 0) return 0;
  const int count = rows.pairs();
  std::vector<bool> outside(static_cast<std::size_t>(count), false);
  int rejected = 0;
  for (int m = 0; m < count; ++m) {
    const MatX H_m = rows.H.middleRows(2 * m, 2);
    const Mat2 S =
        core::symmetrized(Mat2(H_m * P_pred * H_m.transpose()) + rows.noise[static_cast<std::size_t>(m)]);
    const Vec2 nu = rows.innovation.segment<2>(2 * m);
    const Eigen::LLT<Mat2> llt(S);
    if (llt.info() != Eigen::Success) continue;  // cannot gate without S⁻¹: keep
    if (nu.dot(llt.solve(nu)) > chi2_gate) {
      outside[static_cast<std::size_t>(m)] = true;
      ++rejected;
    }
  }
  if (2 * rejected > count) return 0;  // the prediction is off, not the measurements (gate_ranges)
  int kept = 0;
  for (int m = 0; m < count; ++m) {
    if (outside[static_cast<std::size_t>(m)]) continue;
    if (kept != m) {
      rows.H.middleRows(2 * kept, 2) = rows.H.middleRows(2 * m, 2);
      rows.innovation.segment<2>(2 * kept) = rows.innovation.segment<2>(2 * m);
      rows.noise[static_cast<std::size_t>(kept)] = rows.noise[static_cast<std::size_t>(m)];
    }
    ++kept;
  }
  rows.H.conservativeResize(2 * kept, rows.H.cols());
  rows.innovation.conservativeResize(2 * kept);
  rows.noise.resize(static_cast<std::size_t>(kept));
  return count - kept;
}

RowInformation range_bearing_information(const RangeBearingRows& rows) {
  RowInformation info;
  const Eigen::Index n = rows.H.cols();
  info.A = MatX::Zero(n, n);
  info.b = VecX::Zero(n);
  for (int m = 0; m < rows.pairs(); ++m) {
    const MatX H_m = rows.H.middleRows(2 * m, 2);
    const Mat2 R_inv = rows.noise[static_cast<std::size_t>(m)].inverse();
    const MatX HtR = H_m.transpose() * R_inv;  // n×2
    info.A.noalias() += HtR * H_m;
    info.b.noalias() += HtR * rows.innovation.segment<2>(2 * m);
  }
  info.A = 0.5 * (info.A + info.A.transpose());
  return info;
}

std::optional<StackedUpdate> stacked_kalman_update(const VecX& x_pred, const MatX& P_pred,
                                                   const RangeBearingRows& rows) {
  const Eigen::Index n = x_pred.size();
  if (rows.pairs() == 0) return StackedUpdate{x_pred, P_pred};
  const RowInformation info = range_bearing_information(rows);
  const MatX I = MatX::Identity(n, n);
  const MatX PA = P_pred * info.A;
  const MatX M_inv = (I + PA).partialPivLu().inverse();  // I + P A is invertible: P, A PSD
  const MatX I_KH = I - M_inv * PA;
  StackedUpdate out;
  out.mean = x_pred + M_inv * (P_pred * info.b);
  out.covariance = I_KH * P_pred * I_KH.transpose() + M_inv * PA * P_pred * M_inv.transpose();
  out.covariance = 0.5 * (out.covariance + out.covariance.transpose());
  wrap_headings(out.mean);
  if (!out.mean.allFinite() || !out.covariance.allFinite()) return std::nullopt;
  return out;
}

// ---- PoseEkf ----

PoseEkf::PoseEkf(const AgentSetup& setup, const KalmanFamilyParams& params)
    : setup_(setup), params_(params), x_(Pose::Zero()), P_(Mat3::Identity()) {
  validate(setup, params, "pose_ekf");
  x_ = initial_pose(setup);
  P_ = initial_covariance(params);
}

Outbox PoseEkf::initial_outbox() const { return publish(x_, P_.topLeftCorner<2, 2>(), 0); }

StepOutput PoseEkf::step(const StepInput& input) {
  StepOutput out;
  const Predicted predicted = predict_covariance(x_, P_, input.measurements, params_);
  segments_skipped_ += predicted.propagation.segments_skipped;

  const RangeBearingSelection selection = collect_range_bearings(input, setup_.id, params_);
  RangeBearingRows rows = linearize_range_bearings(predicted.pose, selection.targets);
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
  degree_ = batch_degree(input);
  out.outbox = publish(x_, P_.topLeftCorner<2, 2>(), degree_);
  return out;
}

Estimate PoseEkf::estimate() const {
  Estimate estimate;
  estimate.mean_m = x_.head<2>();
  estimate.covariance = P_.topLeftCorner<2, 2>();
  estimate.valid = true;
  estimate.heading = pose_heading_estimate(x_, P_);
  return estimate;
}

// ---- PoseIeif ----

PoseIeif::PoseIeif(const AgentSetup& setup, const KalmanFamilyParams& params)
    : setup_(setup), params_(params), x_(Pose::Zero()), Psi_(Mat3::Identity()) {
  validate(setup, params, "pose_ieif");
  x_ = initial_pose(setup);
  Psi_ = initial_covariance(params).inverse();  // diagonal, positive
}

Mat3 PoseIeif::covariance() const {
  const Eigen::LLT<Mat3> llt(Psi_);
  if (!Psi_.allFinite() || llt.info() != Eigen::Success) return kUndefinedVarianceM2 * Mat3::Identity();
  return symmetrized3(llt.solve(Mat3::Identity()));
}

Outbox PoseIeif::initial_outbox() const { return publish(x_, covariance().topLeftCorner<2, 2>(), 0); }

StepOutput PoseIeif::step(const StepInput& input) {
  StepOutput out;
  PosePropagation prop = propagate_pose(x_, input.measurements, params_);
  // Ψ_F = F⁻ᵀ Ψ F⁻¹, Ψ_{k|k−1} = (I + Ψ_F Q)⁻¹ Ψ_F: the information of F P Fᵀ + Q (valid for singular Ψ).
  const auto predict = [&](const PosePropagation& p) {
    const Mat3 F_inv = p.F.inverse();
    const Mat3 Psi_F = F_inv.transpose() * Psi_ * F_inv;
    return symmetrized3((Mat3::Identity() + Psi_F * p.Q).partialPivLu().solve(Psi_F));
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

  const RangeBearingSelection selection = collect_range_bearings(input, setup_.id, params_);
  RangeBearingRows rows = linearize_range_bearings(x_pred, selection.targets);
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
    const Mat3 Psi_post = symmetrized3(Psi_pred + A);
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
  degree_ = batch_degree(input);
  out.outbox = publish(x_, covariance().topLeftCorner<2, 2>(), degree_);
  return out;
}

Estimate PoseIeif::estimate() const {
  Estimate estimate;
  estimate.mean_m = x_.head<2>();
  const Eigen::LLT<Mat3> llt(Psi_);
  estimate.valid = Psi_.allFinite() && llt.info() == Eigen::Success;
  const Mat3 covariance_now = covariance();
  estimate.covariance = covariance_now.topLeftCorner<2, 2>();
  estimate.heading = pose_heading_estimate(x_, covariance_now);
  return estimate;
}

// ---- DeadReckoning ----

DeadReckoning::DeadReckoning(const AgentSetup& setup, const KalmanFamilyParams& params)
    : setup_(setup), params_(params), x_(Pose::Zero()), P_(Mat3::Identity()) {
  validate(setup, params, "dead_reckoning");
  x_ = initial_pose(setup);
  P_ = initial_covariance(params);
}

Outbox DeadReckoning::initial_outbox() const { return publish(x_, P_.topLeftCorner<2, 2>(), 0); }

StepOutput DeadReckoning::step(const StepInput& input) {
  StepOutput out;
  const Predicted predicted = predict_covariance(x_, P_, input.measurements, params_);
  segments_skipped_ += predicted.propagation.segments_skipped;
  x_ = predicted.pose;
  P_ = predicted.P;
  degree_ = batch_degree(input);
  out.outbox = publish(x_, P_.topLeftCorner<2, 2>(), degree_);
  return out;
}

Estimate DeadReckoning::estimate() const {
  Estimate estimate;
  estimate.mean_m = x_.head<2>();
  estimate.covariance = P_.topLeftCorner<2, 2>();
  estimate.valid = true;
  estimate.heading = pose_heading_estimate(x_, P_);
  return estimate;
}

// ---- CentralizedPoseEkf ----

CentralizedPoseEkf::CentralizedPoseEkf(const std::vector<AgentSetup>& setups,
                                       const KalmanFamilyParams& params)
    : params_(params) {
  const auto n = static_cast<Eigen::Index>(setups.size());
  x_ = VecX::Zero(3 * n);
  P_ = MatX::Zero(3 * n, 3 * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const AgentSetup& setup = setups[static_cast<std::size_t>(i)];
    validate(setup, params, "centralized_pose_ekf");
    if (std::find(ids_.begin(), ids_.end(), setup.id) != ids_.end()) {
      throw std::invalid_argument("centralized_pose_ekf: duplicate agent id " + std::to_string(setup.id));
    }
    ids_.push_back(setup.id);
    x_.segment<3>(3 * i) = initial_pose(setup);
    P_.block<3, 3>(3 * i, 3 * i) = initial_covariance(params);
  }
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
    for (const RangeBearingMeasurement& m : batch->range_bearings) {
      const std::optional<Mat2> R = measurement_noise(m);
      if (!R) {
        ++diagnostics_.neighbours_skipped;
        continue;
      }
      Eigen::Matrix<double, 2, Eigen::Dynamic> H = Eigen::Matrix<double, 2, Eigen::Dynamic>::Zero(2, 3 * n);
      Mat2 noise = *R;
      std::optional<models::RangeBearingEvaluation> h;
      if (m.landmark) {
        const std::optional<Mat2> cov = landmark_covariance(m);
        if (cov) h = models::range_bearing(x_i, m.landmark_m);
        if (!cov || !h) {
          ++diagnostics_.neighbours_skipped;
          continue;
        }
        noise += h->d_target * *cov * h->d_target.transpose();
      } else {
        const std::optional<int> j = index_of(m.peer);
        if (j && *j != i) h = models::range_bearing(x_i, x_.segment<2>(3 * *j));
        if (!j || *j == i || !h) {
          ++diagnostics_.neighbours_skipped;
          continue;
        }
        H.middleCols<2>(3 * *j) = h->d_target;  // the peer's position is in the state
      }
      noise = core::symmetrized(noise);
      if (!invertible_noise(noise)) {
        ++diagnostics_.neighbours_skipped;
        continue;
      }
      H.middleCols<3>(3 * i) = h->d_pose;
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
  estimate.heading = pose_heading_estimate(x_.segment<3>(3 * *i), P_.block<3, 3>(3 * *i, 3 * *i));
  return estimate;
}

Pose CentralizedPoseEkf::pose(AgentId id) const {
  const std::optional<int> i = index_of(id);
  if (!i) throw std::invalid_argument("centralized_pose_ekf: unknown agent id " + std::to_string(id));
  return x_.segment<3>(3 * *i);
}

}  // namespace swarmloc::estimators
