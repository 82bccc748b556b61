#include "swarmloc/models/multipath.hpp"

#include <cmath>

namespace swarmloc::models {

Vec2 unit_direction(double angle_rad) { return Vec2(std::cos(angle_rad), std::sin(angle_rad)); }

Vec2 path_direction(double theta_ij_rad, double theta_ji_rad, double los_threshold) {
  const double alpha = theta_ij_rad;
  const double beta = theta_ji_rad;
  const double s = std::sin(beta - alpha);
  // [D-2]: LOS (opposite rays, cos(β − α) ≈ −1). A folded reflection (parallel rays, cos ≈ +1, pair
  // perpendicular to the wall) keeps eq. (1), which stays exact but ill-conditioned; sin = 0 exactly is 0/0.
  if ((std::abs(s) < los_threshold && std::cos(beta - alpha) < 0.0) || s == 0.0) return unit_direction(alpha);
  // Leng et al. eq. (1)
  return Vec2(std::sin(alpha) + std::sin(beta), -(std::cos(alpha) + std::cos(beta))) / s;
}

Vec2 mirror_across(const Wall& wall, const Vec2& point) {
  const Vec2 u = unit_direction(wall.angle_rad);
  const Vec2 rel = point - wall.point_m;
  return wall.point_m + 2.0 * u * u.dot(rel) - rel;  // (2uuᵀ − I) rel
}

std::optional<PathGeometry> reflect_path(const Vec2& s_i, const Vec2& s_j, const Wall& wall) {
  const Vec2 u = unit_direction(wall.angle_rad);
  const Vec2 normal(-u.y(), u.x());
  const double side_i = normal.dot(s_i - wall.point_m);
  const double side_j = normal.dot(s_j - wall.point_m);
  if (!(side_i * side_j > 0.0)) return std::nullopt;  // both on the same side, strictly
  const Vec2 image = mirror_across(wall, s_j);
  const Vec2 segment = image - s_i;
  const double length = segment.norm();
  if (!(length > 0.0)) return std::nullopt;
  // s_i + λ (s_j′ − s_i) on the wall: side_i + λ (side_j′ − side_i) = 0 with side_j′ = −side_j.
  const double lambda = side_i / (side_i + side_j);
  PathGeometry path;
  path.length_m = length;
  path.scatter_m = s_i + lambda * segment;
  const Vec2 from_i = path.scatter_m - s_i;
  const Vec2 from_j = path.scatter_m - s_j;
  path.theta_ji_rad = std::atan2(from_i.y(), from_i.x());
  path.theta_ij_rad = std::atan2(from_j.y(), from_j.x());
  return path;
}

PathGeometry los_path(const Vec2& s_i, const Vec2& s_j) {
  const Vec2 delta = s_j - s_i;
  PathGeometry path;
  path.length_m = delta.norm();
  path.theta_ji_rad = std::atan2(delta.y(), delta.x());
  path.theta_ij_rad = std::atan2(-delta.y(), -delta.x());
  path.scatter_m = s_j;
  return path;
}

}  // namespace swarmloc::models
