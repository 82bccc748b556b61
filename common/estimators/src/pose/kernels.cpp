// The kernels shared by the pose filters (estimators/pose/kernels.hpp).
#include "swarmloc/estimators/pose/kernels.hpp"

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

Mat3 position_random_walk(const KalmanFilterParams& params) {
  const double q = params.process_noise_std_m * params.process_noise_std_m;
  return Eigen::Vector3d(q, q, 0.0).asDiagonal();
}

PosePropagation propagate_pose(const Pose& pose, const MeasurementBatch* batch,
                               const KalmanFilterParams& params) {
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
        out.Q = pose_internal::symmetrized3(step.F * out.Q * step.F.transpose() + Q);
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
                                             const KalmanFilterParams& params) {
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
    const std::optional<Mat2> R = pose_internal::measurement_noise(m);
    if (!R) {
      ++selection.skipped;
      continue;
    }
    RangeBearingTarget target;
    target.peer = m.peer;
    target.landmark = m.landmark;
    target.measured = Vec2(m.range_m, m.bearing_rad);
    target.noise = *R;
    target.age_s = m.age_s;
    if (m.landmark) {
      const std::optional<Mat2> cov = pose_internal::landmark_covariance(m);
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

Vec2 SightingHistory::inflation(AgentId peer, bool landmark, const Vec2& landmark_m, double time_s,
                                const KalmanFilterParams& params) {
  const double tau = params.sighting_correlation_time_s;
  if (!(tau > 0.0) || !std::isfinite(time_s)) return Vec2::Ones();
  const auto [last, first] = last_time_s_.try_emplace(key_of(peer, landmark, landmark_m, params), time_s);
  if (first) return Vec2::Ones();
  // Two sightings in one step (Δt = 0) are as good as one: ρ close to 1 all but drops the second.
  const double gap_s = std::max(time_s - last->second, 1e-3 * tau);
  last->second = time_s;
  const double rho = std::exp(-gap_s / tau);
  const double correlated = (1.0 + rho) / (1.0 - rho);
  const auto factor = [correlated](double fraction) { return (1.0 - fraction) + fraction * correlated; };
  return Vec2(factor(params.range_correlated_fraction), factor(params.bearing_correlated_fraction));
}

SightingHistory::Key SightingHistory::key_of(AgentId peer, bool landmark, const Vec2& landmark_m,
                                             const KalmanFilterParams& params) const {
  if (!landmark) return Key{peer, false, 0.0, 0.0};
  if (params.sighting_cluster_radius_m > 0.0) {
    for (const auto& [seen, unused] : last_time_s_) {
      if (seen.landmark && (Vec2(seen.x, seen.y) - landmark_m).norm() <= params.sighting_cluster_radius_m) {
        return seen;
      }
    }
  }
  return Key{0, true, landmark_m.x(), landmark_m.y()};
}

void weigh_correlated_sightings(std::vector<RangeBearingTarget>& targets, SightingHistory& history,
                                double time_s, const KalmanFilterParams& params) {
  if (!(params.sighting_correlation_time_s > 0.0)) return;
  for (RangeBearingTarget& target : targets) {
    const Vec2 factor = history.inflation(target.peer, target.landmark, target.target_m, time_s, params);
    target.noise(0, 0) *= factor.x();
    target.noise(1, 1) *= factor.y();
  }
}

RewoundPose rewind_pose(const Pose& end, const OdometryInput* odometry, double age_s) {
  RewoundPose out;
  out.pose = end;
  if (odometry == nullptr || !(age_s > 0.0)) return out;
  // The tail of the step, newest segment first (the earliest one cut at the sighting), skipping the
  // segments propagate_pose skips.
  std::vector<OdometrySegment> tail;
  double left = age_s;
  for (auto it = odometry->segments.rbegin(); it != odometry->segments.rend() && left > 0.0; ++it) {
    if (!std::isfinite(it->v_mps) || !std::isfinite(it->omega_radps) || !std::isfinite(it->dt_s) ||
        it->dt_s < 0.0)
      continue;
    const double dt = std::min(it->dt_s, left);
    tail.push_back({it->v_mps, it->omega_radps, dt});
    left -= dt;
  }
  Pose delta = Pose::Zero();  // the motion from the sighting to the step's end, in the sighting's frame
  for (auto it = tail.rbegin(); it != tail.rend(); ++it) {
    delta = models::unicycle_step(delta, it->v_mps * it->dt_s, it->omega_radps * it->dt_s).pose;
  }
  if (!delta.allFinite()) return out;
  // end = sighting ⊕ delta: θ_s = θ_end − δθ, p_s = p_end − R(θ_s) δ_xy.
  const double theta = models::wrap_angle(end.z() - delta.z());
  const double c = std::cos(theta);
  const double s = std::sin(theta);
  out.pose =
      Pose(end.x() - (c * delta.x() - s * delta.y()), end.y() - (s * delta.x() + c * delta.y()), theta);
  out.d_end(0, 2) = s * delta.x() + c * delta.y();
  out.d_end(1, 2) = -(c * delta.x() - s * delta.y());
  return out;
}

RangeBearingRows linearize_range_bearings(const Pose& pose, const std::vector<RangeBearingTarget>& targets,
                                          const OdometryInput* odometry) {
  RangeBearingRows rows;
  rows.H = MatX::Zero(2 * static_cast<Eigen::Index>(targets.size()), 3);
  rows.innovation = VecX::Zero(rows.H.rows());
  for (const RangeBearingTarget& target : targets) {
    const RewoundPose at = rewind_pose(pose, odometry, target.age_s);
    const auto h = models::range_bearing(at.pose, target.target_m);
    if (!h) {
      ++rows.skipped;  // target at the robot: no direction
      continue;
    }
    // Interlacing: the target's uncertainty enters as noise, R̃ = R + H_t Σ_t H_tᵀ.
    const Mat2 noise =
        core::symmetrized(target.noise + h->d_target * target.target_cov * h->d_target.transpose());
    if (!pose_internal::invertible_noise(noise)) {
      ++rows.skipped;
      continue;
    }
    const Eigen::Index r = 2 * rows.pairs();
    rows.H.block<2, 3>(r, 0) = h->d_pose * at.d_end;
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
  // Two or more sightings outside, and most of them: the prediction is off, not the measurements
  // (gate_ranges). One lone sighting outside is a misread barcode as often as not (docs/real-data.md).
  if (rejected >= 2 && 2 * rejected > count) return 0;
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
  pose_internal::wrap_headings(out.mean);
  if (!out.mean.allFinite() || !out.covariance.allFinite()) return std::nullopt;
  return out;
}

}  // namespace swarmloc::estimators
