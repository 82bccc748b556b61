#pragma once
// Single-bounce (NLOS) and LOS path model of Leng et al. (docs/algorithms.md §5.1): d = g(θ_ij, θ_ji)ᵀ(s_i −
// s_j) (eq. (1)), and path simulation by the image method (§5.4). Pure functions, no state.
#include <optional>

#include "swarmloc/core/types.hpp"

namespace swarmloc::models {

/// Below this |sin(θ_ji − θ_ij)| a path is treated as LOS ([D-2]).
inline constexpr double kLosSinThreshold = 1e-3;

/// Unit vector u(θ) = (cos θ, sin θ).
Vec2 unit_direction(double angle_rad);

/// Leng et al. eq. (1): g(α, β) = [(sin α + sin β), −(cos α + cos β)]ᵀ / sin(β − α), with α = θ_ij (angle at
/// S_j) and β = θ_ji (angle at S_i) so that d_ji = g(θ_ij, θ_ji)ᵀ(s_i − s_j) ([D-1]). LOS fallback [D-2]:
/// if |sin(β − α)| < los_threshold and the rays are opposite (cos(β − α) < 0), g = u(α), the unit vector
/// from S_j toward S_i. Parallel rays (a reflection with the pair perpendicular to the wall) keep eq. (1).
Vec2 path_direction(double theta_ij_rad, double theta_ji_rad, double los_threshold = kLosSinThreshold);

/// A straight wall (infinite line) through `point_m` with direction angle `angle_rad` (0 = horizontal).
struct Wall {
  Vec2 point_m = Vec2::Zero();
  double angle_rad = 0.0;
};

/// One path between S_i and S_j as seen from S_i: its length d_ji and the angles of arrival at both ends.
struct PathGeometry {
  double length_m = 0.0;
  double theta_ji_rad = 0.0;  ///< at S_i, toward the scatter point (or toward S_j for LOS)
  double theta_ij_rad = 0.0;  ///< at S_j, toward the scatter point (or toward S_i for LOS)
  Vec2 scatter_m = Vec2::Zero();
};

/// Mirror image of `point` across the wall line.
Vec2 mirror_across(const Wall& wall, const Vec2& point);

/// Specular reflection of the S_i–S_j path off `wall` by the image method (§5.4): s_j′ = mirror(s_j),
/// length = ‖s_i − s_j′‖, scatter point = segment s_i s_j′ ∩ wall. nullopt if the endpoints lie on
/// different sides of the wall (or on it), or coincide.
std::optional<PathGeometry> reflect_path(const Vec2& s_i, const Vec2& s_j, const Wall& wall);

/// Direct (LOS) path: length ‖s_i − s_j‖, θ_ji = angle of s_j − s_i, θ_ij = angle of s_i − s_j.
PathGeometry los_path(const Vec2& s_i, const Vec2& s_j);

}  // namespace swarmloc::models
