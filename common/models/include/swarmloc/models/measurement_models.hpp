#pragma once
// Planar measurement models with analytic Jacobians (docs/algorithms.md §1.1). Pure functions: no I/O,
// clocks or state. Notation: Δ = x_i − x_j, ρ = ‖Δ‖, u_ij = Δ/ρ (unit vector from j to i).
#include <Eigen/Core>
#include <optional>

#include "swarmloc/core/types.hpp"

namespace swarmloc::models {

using Row2 = Eigen::RowVector2d;

/// Below this distance (m) range and bearing are not differentiable: the row is skipped (§1.1).
inline constexpr double kMinDistanceM = 1e-9;

/// A scalar measurement h(x_i, x_j) with its 1×2 Jacobians.
struct ScalarEvaluation {
  double value = 0.0;
  Row2 d_xi = Row2::Zero();  ///< ∂h/∂x_i
  Row2 d_xj = Row2::Zero();  ///< ∂h/∂x_j
};

/// A 2-vector measurement h(x_i, x_j) with its 2×2 Jacobians.
struct VectorEvaluation {
  Vec2 value = Vec2::Zero();
  Mat2 d_xi = Mat2::Zero();  ///< ∂h/∂x_i
  Mat2 d_xj = Mat2::Zero();  ///< ∂h/∂x_j
};

/// Range ρ; ∂/∂x_i = u_ijᵀ, ∂/∂x_j = −u_ijᵀ (§1.1, Gasparri & Pascucci eq. (44)). nullopt if ρ <
/// kMinDistanceM.
std::optional<ScalarEvaluation> range(const Vec2& x_i, const Vec2& x_j);

/// Squared range ρ²; ∂/∂x_i = 2Δᵀ, ∂/∂x_j = −2Δᵀ (§1.1). Defined everywhere.
ScalarEvaluation squared_range(const Vec2& x_i, const Vec2& x_j);

/// Bearing of j seen from i in the global frame, atan2(y_j − y_i, x_j − x_i) ∈ (−π, π];
/// ∂/∂x_i = −wᵀ/ρ, ∂/∂x_j = +wᵀ/ρ with w ⟂ (x_j − x_i) (§1.1). nullopt if ρ < kMinDistanceM.
std::optional<ScalarEvaluation> bearing(const Vec2& x_i, const Vec2& x_j);

/// Wraps an angle to (−π, π].
double wrap_angle(double angle_rad);

/// Bearing residual measured − predicted wrapped to (−π, π] (§1.1).
double bearing_residual(double measured_rad, double predicted_rad);

/// Absolute/GPS fix h = x_i; ∂/∂x_i = I₂, ∂/∂x_j = 0 (§1.1).
VectorEvaluation absolute_position(const Vec2& x_i);

/// Relative position h = x_j − x_i; ∂/∂x_i = −I₂, ∂/∂x_j = +I₂ (§1.1).
VectorEvaluation relative_position(const Vec2& x_i, const Vec2& x_j);

}  // namespace swarmloc::models
