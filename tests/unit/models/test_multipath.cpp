#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "eigen_gtest.hpp"
#include "swarmloc/models/multipath.hpp"

namespace swarmloc::models {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// Leng et al. eq. (1) for noise-free specular reflections: d = g(θ_ij, θ_ji)ᵀ(s_i − s_j) to machine
// precision.
void expect_eq1_holds_for_wall(double wall_angle_deg) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 10.0);
  const double angle = wall_angle_deg * kDeg;
  const Vec2 normal(-std::sin(angle), std::cos(angle));
  const Wall wall{Vec2(5.0, 5.0) - 12.0 * normal, angle};
  for (int trial = 0; trial < 200; ++trial) {
    const Vec2 s_i(u(rng), u(rng));
    const Vec2 s_j(u(rng), u(rng));
    const auto path = reflect_path(s_i, s_j, wall);
    ASSERT_TRUE(path.has_value());
    const Vec2 g = path_direction(path->theta_ij_rad, path->theta_ji_rad);
    EXPECT_NEAR(g.dot(s_i - s_j), path->length_m, 1e-12 * std::max(1.0, path->length_m));
    // The scatter point lies on the wall and splits the path into the two legs.
    const double legs = (path->scatter_m - s_i).norm() + (path->scatter_m - s_j).norm();
    EXPECT_NEAR(legs, path->length_m, 1e-12 * path->length_m);
    EXPECT_NEAR(normal.dot(path->scatter_m - wall.point_m), 0.0, 1e-11);
  }
}

TEST(Multipath, ReflectionOffHorizontalWallSatisfiesEq1) { expect_eq1_holds_for_wall(0.0); }
TEST(Multipath, ReflectionOff45DegreeWallSatisfiesEq1) { expect_eq1_holds_for_wall(45.0); }
TEST(Multipath, ReflectionOff10DegreeWallSatisfiesEq1) { expect_eq1_holds_for_wall(10.0); }

TEST(Multipath, LosPathFallsBackToUnitVectorAndGivesDistance) {
  const Vec2 s_i(3.0, 4.0);
  const Vec2 s_j(-1.0, 1.0);
  const PathGeometry los = los_path(s_i, s_j);
  const Vec2 g = path_direction(los.theta_ij_rad, los.theta_ji_rad);  // sin(θ_ji − θ_ij) = 0: [D-2]
  EXPECT_MATRIX_NEAR(g, Vec2((s_i - s_j).normalized()), 1e-12);
  EXPECT_NEAR(g.dot(s_i - s_j), 5.0, 1e-12);
  EXPECT_NEAR(los.length_m, 5.0, 1e-12);
}

TEST(Multipath, SwappingTheAnglesFlipsTheSign) {  // [D-1]: g(β, α) = −g(α, β)
  const Vec2 a = path_direction(0.3, 2.0);
  const Vec2 b = path_direction(2.0, 0.3);
  EXPECT_MATRIX_NEAR(a, Vec2(-b), 1e-15);
}

TEST(Multipath, NoReflectionWhenTheWallSeparatesTheNodes) {
  const Wall wall{Vec2(0.0, 0.0), 0.0};
  EXPECT_FALSE(reflect_path(Vec2(1.0, 1.0), Vec2(2.0, -1.0), wall).has_value());
  EXPECT_TRUE(reflect_path(Vec2(1.0, 1.0), Vec2(2.0, 3.0), wall).has_value());
}

TEST(Multipath, MirrorIsAnInvolution) {
  const Wall wall{Vec2(1.0, -2.0), 0.7};
  const Vec2 p(3.0, 5.0);
  EXPECT_MATRIX_NEAR(mirror_across(wall, mirror_across(wall, p)), p, 1e-12);
}

}  // namespace
}  // namespace swarmloc::models
