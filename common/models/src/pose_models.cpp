#include "swarmloc/models/pose_models.hpp"

#include <cmath>

#include "swarmloc/models/measurement_models.hpp"

namespace swarmloc::models {

UnicycleStep unicycle_step(const Pose& pose, double distance_m, double angle_rad) {
  const double d = distance_m;
  const double a = angle_rad;
  // s(a) = sin(a/2)/(a/2) and s'(a) = ds/da; straight line: s = 1, s' = −a/12 (its Taylor term, ≈ 0).
  double s = 1.0;
  double ds = -a / 12.0;
  if (std::abs(a) > kStraightSegmentRad) {
    const double half = 0.5 * a;
    s = std::sin(half) / half;
    ds = 0.5 * (half * std::cos(half) - std::sin(half)) / (half * half);
  }
  const double heading = pose.z() + 0.5 * a;  // mean heading over the arc
  const double c = std::cos(heading);
  const double sn = std::sin(heading);
  UnicycleStep step;
  step.pose = Pose(pose.x() + d * s * c, pose.y() + d * s * sn, wrap_angle(pose.z() + a));
  step.F(0, 2) = -d * s * sn;
  step.F(1, 2) = d * s * c;
  step.G << s * c, d * (ds * c - 0.5 * s * sn),  //
      s * sn, d * (ds * sn + 0.5 * s * c),       //
      0.0, 1.0;
  return step;
}

Mat3 unicycle_process_noise(const Mat32& G, double v_std, double omega_std, double dt_s) {
  const Eigen::Vector2d input_variance(v_std * v_std * dt_s, omega_std * omega_std * dt_s);
  const Mat3 Q = G * input_variance.asDiagonal() * G.transpose();
  return 0.5 * (Q + Q.transpose());
}

std::optional<RangeBearingEvaluation> range_bearing(const Pose& pose, const Vec2& target) {
  const Vec2 position = pose.head<2>();
  const auto rho = range(target, position);    // ∂/∂t = (t − p)ᵀ/ρ, ∂/∂p = −(t − p)ᵀ/ρ
  const auto phi = bearing(position, target);  // global-frame bearing of t from p
  if (!rho || !phi) return std::nullopt;
  RangeBearingEvaluation out;
  out.value = Vec2(rho->value, wrap_angle(phi->value - pose.z()));
  out.d_pose.block<1, 2>(0, 0) = rho->d_xj;
  out.d_pose.block<1, 2>(1, 0) = phi->d_xi;
  out.d_pose(1, 2) = -1.0;
  out.d_target.row(0) = rho->d_xi;
  out.d_target.row(1) = phi->d_xj;
  return out;
}

}  // namespace swarmloc::models
