#pragma once
// Pose-state (x, y, θ) models for ground robots with unicycle odometry and body-frame range-bearing
// sensing (UTIAS MRCLAM). Pure functions with analytic Jacobians: no I/O, clocks or state.
#include <Eigen/Core>
#include <optional>

#include "swarmloc/core/types.hpp"

namespace swarmloc::models {

using Pose = Eigen::Vector3d;  ///< (x, y, θ), θ in (−π, π]
using Mat3 = Eigen::Matrix3d;
using Mat23 = Eigen::Matrix<double, 2, 3>;
using Mat32 = Eigen::Matrix<double, 3, 2>;

/// Below this turned angle |a| (rad) a segment is a straight line (the arc formula is 0/0).
inline constexpr double kStraightSegmentRad = 1e-9;

/// One unicycle segment x' = f(x, d, a) with its Jacobians.
struct UnicycleStep {
  Pose pose = Pose::Zero();   ///< f, θ wrapped to (−π, π]
  Mat3 F = Mat3::Identity();  ///< ∂f/∂pose
  Mat32 G = Mat32::Zero();    ///< ∂f/∂(d, a)
};

/// Moves `pose` by the distance d = v·dt along an arc that turns by a = ω·dt (exact arc):
///   x' = x + d·s(a)·cos(θ + a/2),  y' = y + d·s(a)·sin(θ + a/2),  θ' = wrap(θ + a),
/// with s(a) = sin(a/2)/(a/2) — the same as x + (d/a)(sin(θ + a) − sin θ), y + (d/a)(cos θ − cos(θ + a)),
/// without the cancellation for small a. For |a| <= kStraightSegmentRad: s = 1 (a straight line).
UnicycleStep unicycle_step(const Pose& pose, double distance_m, double angle_rad);

/// Process noise of one segment with white input noise: Q = G diag(v_std²·dt, ω_std²·dt) Gᵀ.
Mat3 unicycle_process_noise(const Mat32& G, double v_std, double omega_std, double dt_s);

/// Range and bearing of a target point t seen from `pose` in the body frame:
/// h = (‖t − p‖, wrap(atan2(t_y − y, t_x − x) − θ)).
struct RangeBearingEvaluation {
  Vec2 value = Vec2::Zero();
  Mat23 d_pose = Mat23::Zero();  ///< ∂h/∂(x, y, θ)
  Mat2 d_target = Mat2::Zero();  ///< ∂h/∂t
};

/// nullopt if ‖t − p‖ < kMinDistanceM (no direction).
std::optional<RangeBearingEvaluation> range_bearing(const Pose& pose, const Vec2& target);

}  // namespace swarmloc::models
