// The batch MAP smoother of pose-state runs (world/pose_smoother.hpp) on small synthetic multi-robot worlds
// from a fixed seed, and the 3-DOF NEES with its heading wrap (world/metrics.hpp).
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "swarmloc/estimators/pose/centralized_pose_ekf.hpp"
#include "swarmloc/estimators/pose/kernels.hpp"
#include "swarmloc/models/measurement_models.hpp"
#include "swarmloc/world/metrics.hpp"
#include "swarmloc/world/pose_smoother.hpp"

namespace swarmloc::world {
namespace {

/// A synthetic run: robots drive unicycle arcs among landmarks; each step's batch holds the noisy
/// odometry (two segments), range-bearings to landmarks within 6 m and, every third step, to the other
/// robots. `outliers` landmark sightings are replaced by the reading of a wrong landmark (a misread barcode).
struct SmootherWorld {
  int robots = 3;
  std::int64_t steps = 0;
  std::vector<Pose> truth;  ///< step · robots + robot
  std::vector<std::vector<estimators::MeasurementBatch>> batches;
  estimators::KalmanFilterParams params;
};

SmootherWorld make_smoother_world(int robots, std::int64_t steps, int outliers, std::uint64_t seed) {
  SmootherWorld world;
  world.robots = robots;
  world.steps = steps;
  world.params.initial_std_m = 0.05;
  world.params.initial_heading_std_rad = 0.05;
  world.params.process_noise_std_m = 0.01;
  world.params.range_bearing_gate_chi2 = 13.8;
  const std::vector<Vec2> landmarks{{0.0, 4.0}, {5.0, -3.0}, {8.0, 5.0}, {-3.0, -2.0}};
  const double v_std = 0.05, omega_std = 0.1, range_std = 0.1, bearing_std = 0.05, dt = 0.05;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  std::vector<Pose> pose;
  for (int i = 0; i < robots; ++i) pose.emplace_back(1.5 * i, 0.5 * i, 0.4 * i);
  int outliers_left = outliers;
  for (std::int64_t k = 0; k < steps; ++k) {
    std::vector<estimators::MeasurementBatch> step_batches(static_cast<std::size_t>(robots));
    for (int i = 0; i < robots; ++i) {
      auto& batch = step_batches[static_cast<std::size_t>(i)];
      batch.world_step = k;
      if (k == 0) continue;
      estimators::OdometryInput odometry;
      odometry.v_std = v_std;
      odometry.omega_std = omega_std;
      for (int s = 0; s < 2; ++s) {
        const double v = 0.6 + 0.1 * i;
        const double omega = 0.5 * std::sin(0.07 * static_cast<double>(k) + i);
        pose[static_cast<std::size_t>(i)] =
            models::unicycle_step(pose[static_cast<std::size_t>(i)], v * dt, omega * dt).pose;
        odometry.segments.push_back(
            {v + v_std / std::sqrt(dt) * normal(rng), omega + omega_std / std::sqrt(dt) * normal(rng), dt});
      }
      batch.odometry = odometry;
    }
    for (int i = 0; i < robots && k > 0; ++i) {
      auto& batch = step_batches[static_cast<std::size_t>(i)];
      const Pose& p = pose[static_cast<std::size_t>(i)];
      auto reading = [&](const Vec2& target) {
        const auto h = models::range_bearing(p, target);
        estimators::RangeBearingMeasurement m;
        m.range_m = h->value.x() + range_std * normal(rng);
        m.bearing_rad = models::wrap_angle(h->value.y() + bearing_std * normal(rng));
        m.range_std_m = range_std;
        m.bearing_std_rad = bearing_std;
        return m;
      };
      for (std::size_t l = 0; l < landmarks.size(); ++l) {
        if ((landmarks[l] - p.head<2>()).norm() > 6.0) continue;
        const bool misread = outliers_left > 0 && k % 7 == 3;
        auto m = reading(landmarks[misread ? (l + 1) % landmarks.size() : l]);
        if (misread) --outliers_left;
        m.landmark = true;
        m.peer = 6 + static_cast<int>(l);
        m.landmark_m = landmarks[l];
        m.landmark_cov = Mat2::Identity() * 1e-6;
        batch.range_bearings.push_back(m);
      }
      if (k % 3 != 0) continue;
      for (int j = 0; j < robots; ++j) {
        if (j == i) continue;
        auto m = reading(pose[static_cast<std::size_t>(j)].head<2>());
        m.peer = j;
        batch.range_bearings.push_back(m);
      }
    }
    world.truth.insert(world.truth.end(), pose.begin(), pose.end());
    world.batches.push_back(std::move(step_batches));
  }
  return world;
}

std::vector<Vec2> start_positions(const SmootherWorld& world) {
  std::vector<Vec2> start;
  for (int i = 0; i < world.robots; ++i) start.push_back(world.truth[static_cast<std::size_t>(i)].head<2>());
  return start;
}
std::vector<double> start_headings(const SmootherWorld& world) {
  std::vector<double> start;
  for (int i = 0; i < world.robots; ++i) start.push_back(world.truth[static_cast<std::size_t>(i)].z());
  return start;
}

PoseSmootherProblem problem_of(const SmootherWorld& world) {
  auto problem = make_pose_smoother_problem(start_positions(world), start_headings(world), world.params);
  for (std::int64_t k = 0; k < world.steps; ++k)
    add_pose_smoother_step(problem, k, world.batches[static_cast<std::size_t>(k)], world.params);
  return problem;
}

/// The centralized EKF's trajectory (poses and 3×3 marginals) on the world's batches.
struct EkfTrack {
  std::vector<Pose> poses;
  std::vector<Mat3> marginals;
};
EkfTrack run_centralized_ekf(const SmootherWorld& world) {
  std::vector<estimators::AgentSetup> setups;
  for (int i = 0; i < world.robots; ++i) {
    estimators::AgentSetup setup;
    setup.id = i;
    setup.initial_guess_m = world.truth[static_cast<std::size_t>(i)].head<2>();
    setup.initial_heading_rad = world.truth[static_cast<std::size_t>(i)].z();
    setups.push_back(setup);
  }
  estimators::CentralizedPoseEkf ekf(setups, world.params);
  EkfTrack track;
  for (const auto& step_batches : world.batches) {
    std::vector<const estimators::MeasurementBatch*> pointers;
    for (const auto& batch : step_batches) pointers.push_back(&batch);
    ekf.step(pointers);
    for (int i = 0; i < world.robots; ++i) {
      const auto estimate = ekf.estimate(i);
      track.poses.emplace_back(estimate.mean_m.x(), estimate.mean_m.y(), estimate.heading->heading_rad);
      Mat3 P;
      P.topLeftCorner<2, 2>() = estimate.covariance;
      P.block<2, 1>(0, 2) = estimate.heading->position_cov_m_rad;
      P.block<1, 2>(2, 0) = estimate.heading->position_cov_m_rad.transpose();
      P(2, 2) = estimate.heading->variance_rad2;
      track.marginals.push_back(P);
    }
  }
  return track;
}

double position_rmse(const std::vector<Pose>& estimate, const std::vector<Pose>& truth) {
  double squared = 0.0;
  for (std::size_t k = 0; k < truth.size(); ++k) squared += (estimate[k] - truth[k]).head<2>().squaredNorm();
  return std::sqrt(squared / static_cast<double>(truth.size()));
}

// ---- The cost written out again, independently of the smoother's assembly (for the brute-force checks) ----

/// Whitened residuals L⁻¹ r (W = Σ⁻¹ = L⁻ᵀ L⁻¹) of every factor, from their definitions.
VecX whitened_residuals(const PoseSmootherProblem& p, const std::vector<Pose>& x,
                        const std::vector<bool>& used) {
  std::vector<double> out;
  auto push = [&](const VecX& r, const MatX& covariance) {
    const Eigen::LLT<MatX> llt(covariance);
    const VecX w = llt.matrixL().solve(r);
    out.insert(out.end(), w.data(), w.data() + w.size());
  };
  auto at = [&](int robot, std::int64_t step) {
    return x[static_cast<std::size_t>(step * p.robots + robot)];
  };
  for (int i = 0; i < p.robots; ++i) {
    const Pose& s = p.start[static_cast<std::size_t>(i)];
    const Pose d = at(i, 0);
    push(Eigen::Vector3d(d.x() - s.x(), d.y() - s.y(), models::wrap_angle(d.z() - s.z())),
         p.start_covariance[static_cast<std::size_t>(i)]);
  }
  for (const auto& f : p.odometry) {
    const Pose a = at(f.robot, f.step - 1);
    const Pose b = at(f.robot, f.step);
    const Eigen::Rotation2Dd rotation(a.z());
    const Vec2 local = rotation.inverse() * (b.head<2>() - a.head<2>());
    push(Eigen::Vector3d(local.x() - f.delta.x(), local.y() - f.delta.y(),
                         models::wrap_angle(b.z() - a.z() - f.delta.z())),
         f.covariance + kPoseSmootherOdometryJitter * Mat3::Identity());
  }
  for (std::size_t m = 0; m < p.range_bearings.size(); ++m) {
    if (!used[m]) continue;
    const auto& f = p.range_bearings[m];
    const Pose seer = at(f.robot, f.step);
    const Vec2 target = f.peer < 0 ? f.landmark_m : Vec2(at(f.peer, f.step).head<2>());
    const Vec2 d = target - seer.head<2>();
    push(Vec2(f.measured.x() - d.norm(),
              models::wrap_angle(f.measured.y() - (std::atan2(d.y(), d.x()) - seer.z()))),
         f.noise);
  }
  return Eigen::Map<VecX>(out.data(), static_cast<Eigen::Index>(out.size()));
}

std::vector<Pose> plus(const std::vector<Pose>& x, const VecX& delta) {
  std::vector<Pose> out = x;
  for (std::size_t k = 0; k < out.size(); ++k) out[k] += delta.segment<3>(static_cast<Eigen::Index>(3 * k));
  return out;
}

/// ∂(whitened residuals)/∂x by central differences.
MatX numeric_jacobian(const PoseSmootherProblem& p, const std::vector<Pose>& x,
                      const std::vector<bool>& used) {
  const VecX r0 = whitened_residuals(p, x, used);
  const auto n = static_cast<Eigen::Index>(3 * x.size());
  MatX J(r0.size(), n);
  const double h = 1e-6;
  for (Eigen::Index c = 0; c < n; ++c) {
    VecX e = VecX::Zero(n);
    e(c) = h;
    J.col(c) = (whitened_residuals(p, plus(x, e), used) - whitened_residuals(p, plus(x, -e), used)) / (2 * h);
  }
  return J;
}

TEST(PoseSmoother, OdometryJacobiansMatchFiniteDifferences) {
  const Pose a(1.0, -2.0, 0.7);
  const Pose b(1.4, -1.5, 1.1);
  const Pose delta(0.3, 0.1, 0.2);
  const auto analytic = odometry_residual(a, b, delta);
  const double h = 1e-7;
  for (int c = 0; c < 3; ++c) {
    const Pose e = Pose::Unit(c) * h;
    const Pose d_a = (odometry_residual(a + e, b, delta).r - odometry_residual(a - e, b, delta).r) / (2 * h);
    const Pose d_b = (odometry_residual(a, b + e, delta).r - odometry_residual(a, b - e, delta).r) / (2 * h);
    EXPECT_LT((d_a - analytic.d_a.col(c)).norm(), 1e-7) << "column " << c;
    EXPECT_LT((d_b - analytic.d_b.col(c)).norm(), 1e-7) << "column " << c;
  }
}

TEST(PoseSmoother, RangeBearingJacobiansMatchFiniteDifferences) {
  const Pose pose(0.5, 1.0, -2.9);
  const Vec2 target(-2.0, 3.0);
  const Vec2 measured(3.0, 1.0);
  const auto analytic = range_bearing_residual(pose, target, measured);
  ASSERT_TRUE(analytic);
  const double h = 1e-7;
  for (int c = 0; c < 3; ++c) {
    const Pose e = Pose::Unit(c) * h;
    const Vec2 d = (range_bearing_residual(pose + e, target, measured)->r -
                    range_bearing_residual(pose - e, target, measured)->r) /
                   (2 * h);
    EXPECT_LT((d - analytic->d_pose.col(c)).norm(), 1e-7) << "pose column " << c;
  }
  for (int c = 0; c < 2; ++c) {
    const Vec2 e = Vec2::Unit(c) * h;
    const Vec2 d = (range_bearing_residual(pose, target + e, measured)->r -
                    range_bearing_residual(pose, target - e, measured)->r) /
                   (2 * h);
    EXPECT_LT((d - analytic->d_target.col(c)).norm(), 1e-7) << "target column " << c;
  }
}

TEST(PoseSmoother, OdometryFactorIsTheFiltersPredictionFromAnyPose) {
  // x_k = x_{k−1} ⊕ Δ with noise R Q Rᵀ: propagate_pose from the origin, moved rigidly, is propagate_pose
  // from the pose itself.
  estimators::MeasurementBatch batch;
  estimators::OdometryInput odometry;
  odometry.v_std = 0.05;
  odometry.omega_std = 0.1;
  odometry.segments = {{0.5, 0.8, 0.04}, {0.4, -0.3, 0.06}};
  batch.odometry = odometry;
  const estimators::KalmanFilterParams params;
  const Pose from(2.0, -1.0, 2.5);
  const auto relative = estimators::propagate_pose(Pose::Zero(), &batch, params);
  const auto direct = estimators::propagate_pose(from, &batch, params);
  const auto residual = odometry_residual(from, direct.pose, relative.pose);
  EXPECT_LT(residual.r.norm(), 1e-12);
  Mat3 rotation = Mat3::Identity();
  rotation.topLeftCorner<2, 2>() = Eigen::Rotation2Dd(from.z()).toRotationMatrix();
  EXPECT_LT((rotation * relative.Q * rotation.transpose() - direct.Q).norm(), 1e-12);
}

TEST(PoseSmoother, BeatsTheCentralizedEkfAndGatesMisreadBarcodes) {
  const auto world = make_smoother_world(3, 150, 4, 2024);
  const auto problem = problem_of(world);
  const auto ekf = run_centralized_ekf(world);
  const auto solution = solve_pose_smoother(problem, ekf.poses, ekf.marginals);
  EXPECT_TRUE(solution.converged);
  const double smoother_rmse = position_rmse(solution.poses, world.truth);
  const double ekf_rmse = position_rmse(ekf.poses, world.truth);
  EXPECT_LT(smoother_rmse, 0.9 * ekf_rmse) << "smoother " << smoother_rmse << " m, EKF " << ekf_rmse << " m";
  EXPECT_GE(solution.range_bearings_gated, 4);  // at least the misread barcodes
  // Consistent: the mean 3-DOF NEES over every robot-step near 3.
  MeanNees nees;
  for (std::size_t k = 0; k < world.truth.size(); ++k)
    nees.add(pose_nees(solution.poses[k], solution.marginals[k], world.truth[k]));
  EXPECT_EQ(nees.count, world.truth.size());
  EXPECT_GT(nees.mean(), 1.0);
  EXPECT_LT(nees.mean(), 6.0);
}

TEST(PoseSmoother, GradientVanishesAtTheSolution) {
  const auto world = make_smoother_world(3, 60, 0, 7);
  const auto problem = problem_of(world);
  const auto ekf = run_centralized_ekf(world);
  const auto solution = solve_pose_smoother(problem, ekf.poses, ekf.marginals, {.marginals = false});
  ASSERT_TRUE(solution.converged);
  // The normal equations' right-hand side, and the gradient of the independently written cost.
  EXPECT_LT(pose_smoother_gradient(problem, solution.poses, solution.used).lpNorm<Eigen::Infinity>(), 1e-6);
  const VecX r = whitened_residuals(problem, solution.poses, solution.used);
  const VecX gradient = numeric_jacobian(problem, solution.poses, solution.used).transpose() * r;
  EXPECT_LT(gradient.lpNorm<Eigen::Infinity>(), 1e-4);
  // Away from it, the right-hand side is the gradient of ½ Σ rᵀ W r.
  VecX shift = VecX::Constant(static_cast<Eigen::Index>(3 * solution.poses.size()), 0.01);
  const auto moved = plus(solution.poses, shift);
  const VecX expected = numeric_jacobian(problem, moved, solution.used).transpose() *
                        whitened_residuals(problem, moved, solution.used);
  EXPECT_LT((pose_smoother_gradient(problem, moved, solution.used) - expected).lpNorm<Eigen::Infinity>(),
            1e-4 * std::max(1.0, expected.lpNorm<Eigen::Infinity>()));
}

TEST(PoseSmoother, SmallProblemEqualsADenseGaussNewtonSolveAndItsInverse) {
  const auto world = make_smoother_world(2, 7, 0, 11);
  auto problem = problem_of(world);
  problem.gate_chi2 = 0.0;  // every pair in: the dense solve uses them all
  ASSERT_FALSE(problem.range_bearings.empty());
  ASSERT_TRUE(std::any_of(problem.range_bearings.begin(), problem.range_bearings.end(),
                          [](const PoseRangeBearingFactor& f) { return f.peer >= 0; }));
  const auto ekf = run_centralized_ekf(world);
  const auto solution = solve_pose_smoother(problem, ekf.poses, {});
  ASSERT_TRUE(solution.converged);
  // Dense Gauss–Newton on numeric Jacobians of the cost written out in this file.
  const std::vector<bool> all(problem.range_bearings.size(), true);
  std::vector<Pose> x = ekf.poses;
  MatX J;
  for (int iteration = 0; iteration < 30; ++iteration) {
    J = numeric_jacobian(problem, x, all);
    const VecX r = whitened_residuals(problem, x, all);
    const VecX delta = (J.transpose() * J).ldlt().solve(-J.transpose() * r);
    x = plus(x, delta);
    if (delta.lpNorm<Eigen::Infinity>() < 1e-11) break;
  }
  for (std::size_t k = 0; k < x.size(); ++k) {
    EXPECT_LT((solution.poses[k] - x[k]).norm(), 1e-7) << "pose " << k;
  }
  J = numeric_jacobian(problem, x, all);
  const MatX covariance = (J.transpose() * J).inverse();
  ASSERT_EQ(solution.marginals.size(), x.size());
  for (std::size_t k = 0; k < x.size(); ++k) {
    const auto at = static_cast<Eigen::Index>(3 * k);
    const Mat3 dense = covariance.block<3, 3>(at, at);
    EXPECT_LT((solution.marginals[k] - dense).norm(), 1e-6 * dense.norm()) << "pose " << k;
  }
}

TEST(PoseNees, HeadingErrorAcrossPiIsWrapped) {
  const Mat3 covariance = Eigen::Vector3d(0.01, 0.01, 1e-4).asDiagonal();
  const Pose truth(1.0, 2.0, -std::numbers::pi + 0.01);
  const Pose estimate(1.0, 2.0, std::numbers::pi - 0.01);  // 0.02 rad off, across ±π
  const auto nees = pose_nees(estimate, covariance, truth);
  ASSERT_TRUE(nees);
  EXPECT_NEAR(*nees, 4.0, 1e-9);  // (0.02)² / 1e-4
  estimators::Estimate with_heading;
  with_heading.valid = true;
  with_heading.mean_m = Vec2(1.1, 2.0);
  with_heading.covariance = Mat2::Identity() * 0.01;
  with_heading.heading = estimators::HeadingEstimate{std::numbers::pi - 0.01, 1e-4, Vec2::Zero()};
  const auto from_estimate = pose_nees(with_heading, truth.head<2>(), truth.z());
  ASSERT_TRUE(from_estimate);
  EXPECT_NEAR(*from_estimate, 1.0 + 4.0, 1e-9);
  with_heading.heading.reset();  // a position-only estimate has no 3-DOF NEES
  EXPECT_FALSE(pose_nees(with_heading, truth.head<2>(), truth.z()));
}

}  // namespace
}  // namespace swarmloc::world
