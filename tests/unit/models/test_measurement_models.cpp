#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "eigen_gtest.hpp"
#include "swarmloc/models/measurement_models.hpp"

namespace swarmloc::models {
namespace {

/// Any model in a common shape: value (m-vector) and its m×2 Jacobians.
struct Linearized {
  VecX value;
  MatX d_xi;
  MatX d_xj;
};

Linearized from_scalar(const ScalarEvaluation& e) {
  return Linearized{VecX::Constant(1, e.value), e.d_xi, e.d_xj};
}
Linearized from_vector(const VectorEvaluation& e) { return Linearized{e.value, e.d_xi, e.d_xj}; }

/// Compares analytic Jacobians with central finite differences (docs/style.md: one line per model).
/// `angular` wraps value differences to (−π, π].
template <typename Model>
void expect_jacobians_match(Model model, const Vec2& x_i, const Vec2& x_j, bool angular = false,
                            double tolerance = 1e-6) {
  constexpr double kStep = 1e-6;
  const Linearized at = model(x_i, x_j);
  MatX numeric_i(at.value.size(), 2);
  MatX numeric_j(at.value.size(), 2);
  for (int k = 0; k < 2; ++k) {
    const Vec2 e = Vec2::Unit(k) * kStep;
    VecX di = model(x_i + e, x_j).value - model(x_i - e, x_j).value;
    VecX dj = model(x_i, x_j + e).value - model(x_i, x_j - e).value;
    if (angular) {
      di = di.unaryExpr([](double a) { return wrap_angle(a); });
      dj = dj.unaryExpr([](double a) { return wrap_angle(a); });
    }
    numeric_i.col(k) = di / (2.0 * kStep);
    numeric_j.col(k) = dj / (2.0 * kStep);
  }
  EXPECT_MATRIX_NEAR(at.d_xi, numeric_i, tolerance);
  EXPECT_MATRIX_NEAR(at.d_xj, numeric_j, tolerance);
}

const auto kRange = [](const Vec2& a, const Vec2& b) { return from_scalar(*range(a, b)); };
const auto kSquaredRange = [](const Vec2& a, const Vec2& b) { return from_scalar(squared_range(a, b)); };
const auto kBearing = [](const Vec2& a, const Vec2& b) { return from_scalar(*bearing(a, b)); };
const auto kAbsolute = [](const Vec2& a, const Vec2&) { return from_vector(absolute_position(a)); };
const auto kRelative = [](const Vec2& a, const Vec2& b) { return from_vector(relative_position(a, b)); };

const std::vector<std::pair<Vec2, Vec2>> kPoints = {
    {Vec2(0.0, 0.0), Vec2(3.0, 4.0)},
    {Vec2(-1.5, 2.25), Vec2(7.0, -3.0)},
    {Vec2(10.0, 10.0), Vec2(10.1, 9.95)},
    {Vec2(-4.0, 1.0), Vec2(-8.0, 1.5)},  // bearing near ±π: differences are wrapped
};

TEST(MeasurementModels, RangeJacobiansMatchFiniteDifferences) {
  for (const auto& [a, b] : kPoints) expect_jacobians_match(kRange, a, b);
}

TEST(MeasurementModels, SquaredRangeJacobiansMatchFiniteDifferences) {
  for (const auto& [a, b] : kPoints) expect_jacobians_match(kSquaredRange, a, b);
}

TEST(MeasurementModels, BearingJacobiansMatchFiniteDifferences) {
  for (const auto& [a, b] : kPoints) expect_jacobians_match(kBearing, a, b, /*angular=*/true);
}

TEST(MeasurementModels, AbsolutePositionJacobiansMatchFiniteDifferences) {
  for (const auto& [a, b] : kPoints) expect_jacobians_match(kAbsolute, a, b);
}

TEST(MeasurementModels, RelativePositionJacobiansMatchFiniteDifferences) {
  for (const auto& [a, b] : kPoints) expect_jacobians_match(kRelative, a, b);
}

void check_a_wrong_jacobian() {
  const auto wrong = [](const Vec2& a, const Vec2& b) {
    Linearized l = from_scalar(*range(a, b));
    l.d_xj = -0.9 * l.d_xj;  // wrong sign and scale
    return l;
  };
  expect_jacobians_match(wrong, Vec2(0.0, 0.0), Vec2(3.0, 4.0));
}

TEST(MeasurementModels, JacobianCheckDetectsAWrongJacobian) {
  EXPECT_NONFATAL_FAILURE(check_a_wrong_jacobian(), "differ by");
}

TEST(MeasurementModels, ValuesMatchTheirDefinitions) {
  const Vec2 x_i(1.0, 2.0);
  const Vec2 x_j(4.0, 6.0);
  EXPECT_DOUBLE_EQ(range(x_i, x_j)->value, 5.0);
  EXPECT_MATRIX_NEAR(range(x_i, x_j)->d_xi, Row2(-0.6, -0.8), 1e-15);  // u_ij points from j to i
  EXPECT_DOUBLE_EQ(squared_range(x_i, x_j).value, 25.0);
  EXPECT_DOUBLE_EQ(bearing(x_i, x_j)->value, std::atan2(4.0, 3.0));
  EXPECT_MATRIX_NEAR(relative_position(x_i, x_j).value, Vec2(3.0, 4.0), 0.0);
  EXPECT_MATRIX_NEAR(absolute_position(x_i).value, x_i, 0.0);
}

TEST(MeasurementModels, RangeAndBearingRejectCoincidentPositions) {
  const Vec2 x(2.0, -1.0);
  EXPECT_FALSE(range(x, x).has_value());
  EXPECT_FALSE(bearing(x, x).has_value());
  EXPECT_FALSE(range(x, x + Vec2(1e-10, 0.0)).has_value());
  EXPECT_TRUE(range(x, x + Vec2(1e-8, 0.0)).has_value());
  EXPECT_DOUBLE_EQ(squared_range(x, x).value, 0.0);
}

TEST(MeasurementModels, WrapAngleMapsIntoHalfOpenInterval) {
  constexpr double kPi = std::numbers::pi;
  EXPECT_DOUBLE_EQ(wrap_angle(kPi), kPi);
  EXPECT_DOUBLE_EQ(wrap_angle(-kPi), kPi);
  EXPECT_NEAR(wrap_angle(3.0 * kPi), kPi, 1e-12);
  EXPECT_NEAR(wrap_angle(0.5 + 4.0 * kPi), 0.5, 1e-12);
  EXPECT_NEAR(bearing_residual(kPi - 0.1, -kPi + 0.1), -0.2, 1e-12);
  EXPECT_NEAR(bearing_residual(-kPi + 0.1, kPi - 0.1), 0.2, 1e-12);
}

}  // namespace
}  // namespace swarmloc::models
