// Unicycle odometry and body-frame range-bearing models (pose_models.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "eigen_gtest.hpp"
#include "swarmloc/models/measurement_models.hpp"
#include "swarmloc/models/pose_models.hpp"

namespace swarmloc::models {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kStep = 1e-6;  // central differences: truncation O(h²), rounding O(ε/h)

/// Poses and odometry inputs (d, a) covering: generic, heading near ±π, a ≈ 0 on both sides of the
/// straight-line threshold, large turns, reversing.
struct Case {
  Pose pose;
  double d = 0.0;
  double a = 0.0;
};

std::vector<Case> cases() {
  std::vector<Case> out = {
      {Pose(1.0, 2.0, 0.3), 0.5, 0.2},
      {Pose(-3.0, 0.5, kPi - 1e-3), 0.8, 0.01},    // heading near +π, crosses it
      {Pose(2.0, -1.0, -kPi + 1e-3), 0.8, -0.01},  // heading near −π, crosses it
      {Pose(0.0, 0.0, 1.0), 1.2, 0.0},             // straight line
      {Pose(0.0, 0.0, 1.0), 1.2, 1e-10},           // below the threshold
      {Pose(0.0, 0.0, 1.0), 1.2, 1e-8},            // just above it
      {Pose(5.0, 5.0, -2.0), 0.3, 3.0},            // almost a half turn
      {Pose(5.0, 5.0, 2.5), -0.4, -0.7},           // reversing
  };
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> pos(-10.0, 10.0);
  std::uniform_real_distribution<double> heading(-kPi, kPi);
  std::uniform_real_distribution<double> dist(-1.0, 2.0);
  std::uniform_real_distribution<double> turn(-1.5, 1.5);
  for (int k = 0; k < 20; ++k) out.push_back({Pose(pos(rng), pos(rng), heading(rng)), dist(rng), turn(rng)});
  return out;
}

/// Pose difference with the heading wrapped (finite differences across ±π).
Pose pose_diff(const Pose& a, const Pose& b) {
  Pose d = a - b;
  d.z() = wrap_angle(d.z());
  return d;
}

TEST(PoseModels, UnicycleJacobiansMatchFiniteDifferences) {
  for (const Case& c : cases()) {
    const UnicycleStep at = unicycle_step(c.pose, c.d, c.a);
    Mat3 F_num;
    for (int k = 0; k < 3; ++k) {
      const Pose e = Pose::Unit(k) * kStep;
      F_num.col(k) =
          pose_diff(unicycle_step(c.pose + e, c.d, c.a).pose, unicycle_step(c.pose - e, c.d, c.a).pose) /
          (2.0 * kStep);
    }
    Mat32 G_num;
    G_num.col(0) = pose_diff(unicycle_step(c.pose, c.d + kStep, c.a).pose,
                             unicycle_step(c.pose, c.d - kStep, c.a).pose) /
                   (2.0 * kStep);
    G_num.col(1) = pose_diff(unicycle_step(c.pose, c.d, c.a + kStep).pose,
                             unicycle_step(c.pose, c.d, c.a - kStep).pose) /
                   (2.0 * kStep);
    SCOPED_TRACE(::testing::Message() << "pose " << c.pose.transpose() << " d " << c.d << " a " << c.a);
    EXPECT_MATRIX_NEAR(at.F, F_num, 1e-7);
    EXPECT_MATRIX_NEAR(at.G, G_num, 1e-7);
  }
}

TEST(PoseModels, ArcMatchesTheTextbookFormulaAndWrapsTheHeading) {
  const Pose p(1.0, -2.0, 3.0);
  const double d = 0.7;
  const double a = 0.5;
  const UnicycleStep step = unicycle_step(p, d, a);
  const double r = d / a;
  EXPECT_NEAR(step.pose.x(), p.x() + r * (std::sin(p.z() + a) - std::sin(p.z())), 1e-14);
  EXPECT_NEAR(step.pose.y(), p.y() + r * (std::cos(p.z()) - std::cos(p.z() + a)), 1e-14);
  EXPECT_NEAR(step.pose.z(), 3.5 - 2.0 * kPi, 1e-14);  // 3.5 rad wrapped into (−π, π]
  // A full circle returns to the start.
  const UnicycleStep circle = unicycle_step(p, 2.0 * kPi * 1.5, 2.0 * kPi);
  EXPECT_MATRIX_NEAR(pose_diff(circle.pose, p), Pose::Zero().eval(), 1e-12);
}

TEST(PoseModels, ArcTendsToTheStraightLineAsTheTurnVanishes) {
  const Pose p(2.0, 3.0, -0.8);
  const double d = 1.5;
  const Pose straight = unicycle_step(p, d, 0.0).pose;
  EXPECT_NEAR(straight.x(), p.x() + d * std::cos(p.z()), 1e-15);
  EXPECT_NEAR(straight.y(), p.y() + d * std::sin(p.z()), 1e-15);
  // Off-track error of an arc vs the chord heading is d·a/2: shrinks linearly, no jump at the threshold.
  for (const double a : {1e-2, 1e-4, 1e-6, 1e-8, 1.001e-9, 0.999e-9, 1e-12}) {
    const UnicycleStep arc = unicycle_step(p, d, a);
    EXPECT_LE((arc.pose.head<2>() - straight.head<2>()).norm(), 0.5 * d * a * 1.0001 + 1e-15) << "a " << a;
    EXPECT_MATRIX_NEAR(arc.G, unicycle_step(p, d, 0.0).G, 0.6 * d * a + 1e-15);
  }
}

TEST(PoseModels, ProcessNoiseIsGDiagGTransposed) {
  const UnicycleStep step = unicycle_step(Pose(0.0, 0.0, 0.4), 0.3, 0.1);
  const Mat3 Q = unicycle_process_noise(step.G, 0.2, 0.05, 0.5);
  Eigen::Matrix2d D = Eigen::Matrix2d::Zero();
  D(0, 0) = 0.2 * 0.2 * 0.5;
  D(1, 1) = 0.05 * 0.05 * 0.5;
  EXPECT_MATRIX_NEAR(Q, (step.G * D * step.G.transpose()).eval(), 1e-15);
  EXPECT_NEAR(Q(2, 2), 0.05 * 0.05 * 0.5, 1e-15);  // the heading only sees the turn noise
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Mat3>(Q).eigenvalues().minCoeff(), -1e-15);
}

TEST(PoseModels, RangeBearingJacobiansMatchFiniteDifferences) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> pos(-10.0, 10.0);
  std::uniform_real_distribution<double> heading(-kPi, kPi);
  std::vector<std::pair<Pose, Vec2>> points = {
      {Pose(0.0, 0.0, 0.0), Vec2(3.0, 4.0)},
      {Pose(1.0, 1.0, kPi - 1e-4), Vec2(-2.0, 1.0)},  // bearing ≈ 0 from a heading near π
      {Pose(1.0, 1.0, 0.1), Vec2(-2.0, 1.0 + 1e-5)},  // global bearing near ±π
      {Pose(-4.0, 2.0, -kPi + 1e-4), Vec2(-4.1, 2.05)},
  };
  for (int k = 0; k < 20; ++k)
    points.emplace_back(Pose(pos(rng), pos(rng), heading(rng)), Vec2(pos(rng), pos(rng)));
  const auto h = [](const Pose& p, const Vec2& t) { return range_bearing(p, t)->value; };
  const auto diff = [](const Vec2& a, const Vec2& b) {
    return Vec2(a.x() - b.x(), wrap_angle(a.y() - b.y()));
  };
  for (const auto& [p, t] : points) {
    const auto at = range_bearing(p, t);
    ASSERT_TRUE(at.has_value());
    Mat23 H_pose_num;
    for (int k = 0; k < 3; ++k) {
      const Pose e = Pose::Unit(k) * kStep;
      H_pose_num.col(k) = diff(h(p + e, t), h(p - e, t)) / (2.0 * kStep);
    }
    Mat2 H_target_num;
    for (int k = 0; k < 2; ++k) {
      const Vec2 e = Vec2::Unit(k) * kStep;
      H_target_num.col(k) = diff(h(p, t + e), h(p, t - e)) / (2.0 * kStep);
    }
    SCOPED_TRACE(::testing::Message() << "pose " << p.transpose() << " target " << t.transpose());
    // Central differences err by O(h²/ρ³) (curvature of the bearing) + O(ε·|h|/h) (rounding).
    const double rho = (t - p.head<2>()).norm();
    const double tolerance = 1e-7 * std::max(1.0, 1.0 / (rho * rho * rho));
    EXPECT_MATRIX_NEAR(at->d_pose, H_pose_num, tolerance);
    EXPECT_MATRIX_NEAR(at->d_target, H_target_num, tolerance);
  }
}

TEST(PoseModels, BearingIsInTheBodyFrameAndWrapped) {
  // Target straight ahead, to the left, behind.
  EXPECT_NEAR(range_bearing(Pose(0.0, 0.0, kPi / 2), Vec2(0.0, 2.0))->value.y(), 0.0, 1e-15);
  EXPECT_NEAR(range_bearing(Pose(0.0, 0.0, 0.0), Vec2(0.0, 2.0))->value.y(), kPi / 2, 1e-15);
  EXPECT_NEAR(range_bearing(Pose(1.0, 1.0, 0.0), Vec2(4.0, 5.0))->value.x(), 5.0, 1e-15);
  // Global bearing −(π − 0.1), heading +(π − 0.1): the raw difference −2π + 0.2 wraps to +0.2.
  const double g = -(kPi - 0.1);
  const Vec2 target(std::cos(g), std::sin(g));
  const double beta = range_bearing(Pose(0.0, 0.0, kPi - 0.1), target)->value.y();
  EXPECT_NEAR(beta, 0.2, 1e-12);
  EXPECT_GT(beta, -kPi);
  EXPECT_LE(beta, kPi);
  // Target behind: exactly +π (the half-open interval).
  EXPECT_NEAR(range_bearing(Pose(0.0, 0.0, 0.0), Vec2(-1.0, 0.0))->value.y(), kPi, 1e-15);
}

TEST(PoseModels, RangeBearingUndefinedAtTheRobot) {
  EXPECT_FALSE(range_bearing(Pose(1.0, 2.0, 0.3), Vec2(1.0, 2.0)).has_value());
  EXPECT_FALSE(range_bearing(Pose(1.0, 2.0, 0.3), Vec2(1.0 + 1e-10, 2.0)).has_value());
  EXPECT_TRUE(range_bearing(Pose(1.0, 2.0, 0.3), Vec2(1.0 + 1e-6, 2.0)).has_value());
}

}  // namespace
}  // namespace swarmloc::models
