#include "swarmloc/models/measurement_models.hpp"

#include <cmath>
#include <numbers>

namespace swarmloc::models {

std::optional<ScalarEvaluation> range(const Vec2& x_i, const Vec2& x_j) {
  const Vec2 delta = x_i - x_j;
  const double rho = delta.norm();
  if (!(rho >= kMinDistanceM)) return std::nullopt;
  const Row2 u = (delta / rho).transpose();  // docs/algorithms.md §1.1: u_ijᵀ
  return ScalarEvaluation{rho, u, -u};
}

ScalarEvaluation squared_range(const Vec2& x_i, const Vec2& x_j) {
  const Vec2 delta = x_i - x_j;
  return ScalarEvaluation{delta.squaredNorm(), 2.0 * delta.transpose(), -2.0 * delta.transpose()};
}

std::optional<ScalarEvaluation> bearing(const Vec2& x_i, const Vec2& x_j) {
  const Vec2 d = x_j - x_i;
  const double rho = d.norm();
  if (!(rho >= kMinDistanceM)) return std::nullopt;
  const Row2 w(-d.y() / rho, d.x() / rho);  // unit vector ⟂ (x_j − x_i)
  return ScalarEvaluation{std::atan2(d.y(), d.x()), -w / rho, w / rho};
}

double wrap_angle(double angle_rad) {
  constexpr double kTwoPi = 2.0 * std::numbers::pi;
  double wrapped = std::remainder(angle_rad, kTwoPi);  // [−π, π]
  if (wrapped <= -std::numbers::pi) wrapped += kTwoPi;
  return wrapped;
}

double bearing_residual(double measured_rad, double predicted_rad) {
  return wrap_angle(measured_rad - predicted_rad);
}

VectorEvaluation absolute_position(const Vec2& x_i) {
  return VectorEvaluation{x_i, Mat2::Identity(), Mat2::Zero()};
}

VectorEvaluation relative_position(const Vec2& x_i, const Vec2& x_j) {
  return VectorEvaluation{x_j - x_i, -Mat2::Identity(), Mat2::Identity()};
}

}  // namespace swarmloc::models
