// Pose-state filters (pose/*.hpp): PoseEkf, PoseIeif, DeadReckoning, CentralizedPoseEkf.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <numbers>
#include <random>
#include <vector>

#include "eigen_gtest.hpp"
#include "named_estimators.hpp"
#include "pose_world.hpp"
#include "swarmloc/core/gaussian.hpp"
#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/pose/centralized_pose_ekf.hpp"
#include "swarmloc/estimators/pose/dead_reckoning.hpp"
#include "swarmloc/estimators/pose/kernels.hpp"
#include "swarmloc/estimators/pose/pose_ekf.hpp"
#include "swarmloc/estimators/pose/pose_ieif.hpp"
#include "swarmloc/models/measurement_models.hpp"

namespace swarmloc::estimators {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
using pose_world::params_for;
using pose_world::simulate;
using pose_world::World;
using pose_world::WorldConfig;

/// Pose error with the heading wrapped.
Pose pose_error(const Pose& estimate, const Pose& truth) {
  Pose e = estimate - truth;
  e.z() = models::wrap_angle(e.z());
  return e;
}

struct RunStats {
  double rmse_last_half_m = 0.0;  ///< position RMSE over the robots and the last half of the steps
  double mean_nees = 0.0;         ///< 3-state NEES averaged over robots and steps (from step kNeesFrom)
  std::vector<double> nees_sums;  ///< per step (from kNeesFrom): NEES summed over the robots
  int robots = 0;
  bool covariances_ok = true;  ///< symmetric PSD with a finite state after every step
};

constexpr int kNeesFrom = 10;  // skip the first steps (linearization at the prior)

struct Accumulator {
  int robots = 0;
  double squared_error = 0.0;
  int error_samples = 0;
  std::vector<double> nees_sums;
  bool covariances_ok = true;

  void add(int k, int steps, const Pose& estimate, const Mat3& P, const Pose& truth) {
    const Pose e = pose_error(estimate, truth);
    if (2 * k >= steps) {
      squared_error += e.head<2>().squaredNorm();
      ++error_samples;
    }
    const bool symmetric = (P - P.transpose()).cwiseAbs().maxCoeff() <= 1e-12 * P.cwiseAbs().maxCoeff();
    const Eigen::SelfAdjointEigenSolver<Mat3> eig(P);
    if (!estimate.allFinite() || !P.allFinite() || !symmetric || !(eig.eigenvalues().minCoeff() > 0.0)) {
      covariances_ok = false;
      return;
    }
    if (k >= kNeesFrom) {
      const auto index = static_cast<std::size_t>(k - kNeesFrom);
      if (nees_sums.size() <= index) nees_sums.resize(index + 1, 0.0);
      nees_sums[index] += e.dot(P.ldlt().solve(e));
    }
  }
  [[nodiscard]] RunStats stats() const {
    RunStats out;
    out.rmse_last_half_m = std::sqrt(squared_error / std::max(1, error_samples));
    out.nees_sums = nees_sums;
    out.robots = robots;
    double total = 0.0;
    for (const double sum : nees_sums) total += sum;
    out.mean_nees = total / std::max<double>(1.0, static_cast<double>(nees_sums.size()) * robots);
    out.covariances_ok = covariances_ok;
    return out;
  }
};

/// Chi-square quantile (Wilson–Hilferty; within 0.1 % of the exact value for ν >= 30).
double chi2_quantile(double nu, double z) {
  const double c = 2.0 / (9.0 * nu);
  return nu * std::pow(1.0 - c + z * std::sqrt(c), 3.0);
}

/// Bar-Shalom's NEES test over R independent trajectories (runs × robots): at each step the average NEES
/// is χ²(3R)/R for a consistent filter. Returns the time average of that and the fraction of steps whose
/// average lies in the two-sided 95 % band.
struct NeesCheck {
  double mean = 0.0;
  double inside = 0.0;
  double lower = 0.0;
  double upper = 0.0;
};

NeesCheck nees_check(const std::vector<RunStats>& runs) {
  int trajectories = 0;
  for (const RunStats& run : runs) trajectories += run.robots;
  const double r = trajectories;
  NeesCheck check;
  check.lower = chi2_quantile(3.0 * r, -1.96) / r;
  check.upper = chi2_quantile(3.0 * r, 1.96) / r;
  const std::size_t steps = runs.front().nees_sums.size();
  int inside = 0;
  for (std::size_t k = 0; k < steps; ++k) {
    double sum = 0.0;
    for (const RunStats& run : runs) sum += run.nees_sums.at(k);
    const double average = sum / r;
    check.mean += average / static_cast<double>(steps);
    if (average >= check.lower && average <= check.upper) ++inside;
  }
  check.inside = static_cast<double>(inside) / static_cast<double>(steps);
  return check;
}

/// Runs one per-agent algorithm on every robot. Messages are exchanged between steps (each robot's
/// step k sees the others' messages published after their step k − 1). `use_peers` = false drops the
/// robot-robot pairs from the batches (landmarks only).
template <typename Filter>
RunStats run_distributed(const WorldConfig& c, const World& world, bool use_peers = true) {
  const KalmanFilterParams params = params_for(c);
  std::vector<std::unique_ptr<Filter>> filters;
  Inbox shared;
  for (const AgentSetup& setup : world.setups) {
    filters.push_back(std::make_unique<Filter>(setup, params));
    shared.states.push_back(Received<StateMessage>{setup.id, -1, *filters.back()->initial_outbox().state});
  }
  Accumulator acc;
  acc.robots = c.robots;
  for (int k = 0; k < c.steps; ++k) {
    Inbox next;
    for (std::size_t i = 0; i < filters.size(); ++i) {
      MeasurementBatch batch = world.batches[static_cast<std::size_t>(k)][i];
      if (!use_peers) std::erase_if(batch.range_bearings, [](const auto& m) { return !m.landmark; });
      const StepOutput out = filters[i]->step(StepInput{k, &batch, &shared});
      next.states.push_back(Received<StateMessage>{static_cast<AgentId>(i), k, *out.outbox.state});
      acc.add(k, c.steps, filters[i]->pose(), filters[i]->covariance(),
              world.truth[static_cast<std::size_t>(k)][i]);
    }
    shared = next;
  }
  return acc.stats();
}

RunStats run_centralized(const WorldConfig& c, const World& world) {
  CentralizedPoseEkf filter(world.setups, params_for(c));
  Accumulator acc;
  acc.robots = c.robots;
  for (int k = 0; k < c.steps; ++k) {
    std::vector<const MeasurementBatch*> batches;
    for (const auto& batch : world.batches[static_cast<std::size_t>(k)]) batches.push_back(&batch);
    filter.step(batches);
    const MatX& P = filter.covariance();
    const bool joint_ok = core::is_symmetric_psd_dynamic(P, 1e-12);
    for (int i = 0; i < c.robots; ++i) {
      acc.add(k, c.steps, filter.pose(i), P.block<3, 3>(3 * i, 3 * i),
              world.truth[static_cast<std::size_t>(k)][static_cast<std::size_t>(i)]);
    }
    if (!joint_ok) acc.covariances_ok = false;
  }
  return acc.stats();
}

WorldConfig landmark_rich(unsigned seed) {
  WorldConfig c;
  c.seed = seed;
  c.landmarks = {Vec2(-5.0, -5.0), Vec2(0.0, -5.5), Vec2(5.0, -5.0),
                 Vec2(5.0, 5.0),   Vec2(0.0, 5.5),  Vec2(-5.0, 5.0)};
  return c;
}

/// One landmark, seen only near it: robots far from it localize through each other.
WorldConfig few_landmarks(unsigned seed) {
  WorldConfig c;
  c.seed = seed;
  c.landmarks = {Vec2(4.0, 0.0)};
  c.landmark_radius_m = 3.0;
  c.robot_radius_m = 6.0;
  return c;
}

// ---- (a) accuracy and consistency in the simulated world ----

TEST(PoseFilters, EkfBeatsDeadReckoningWithLandmarksAndIsConsistent) {
  std::vector<RunStats> landmark_only_runs;
  std::vector<RunStats> centralized_runs;
  for (const unsigned seed : {1U, 2U, 3U}) {
    const WorldConfig c = landmark_rich(seed);
    const World world = simulate(c);
    const RunStats ekf = run_distributed<PoseEkf>(c, world);
    const RunStats landmarks_only = run_distributed<PoseEkf>(c, world, /*use_peers=*/false);
    const RunStats dr = run_distributed<DeadReckoning>(c, world);
    const RunStats centralized = run_centralized(c, world);
    std::printf(
        "seed %u: RMSE pose_ekf %.4f m (NEES %.2f), pose_ekf landmarks only %.4f m (NEES %.2f), centralized "
        "%.4f m (NEES %.2f), dead reckoning %.3f m (%.1fx pose_ekf)\n",
        seed, ekf.rmse_last_half_m, ekf.mean_nees, landmarks_only.rmse_last_half_m, landmarks_only.mean_nees,
        centralized.rmse_last_half_m, centralized.mean_nees, dr.rmse_last_half_m,
        dr.rmse_last_half_m / ekf.rmse_last_half_m);
    for (const RunStats* run : {&ekf, &landmarks_only, &dr, &centralized}) EXPECT_TRUE(run->covariances_ok);
    EXPECT_LT(ekf.rmse_last_half_m, 0.12) << "seed " << seed;
    EXPECT_LT(landmarks_only.rmse_last_half_m, 0.15) << "seed " << seed;
    EXPECT_GT(dr.rmse_last_half_m, 5.0 * ekf.rmse_last_half_m) << "seed " << seed;
    EXPECT_GT(dr.rmse_last_half_m, 5.0 * landmarks_only.rmse_last_half_m) << "seed " << seed;
    landmark_only_runs.push_back(landmarks_only);
    centralized_runs.push_back(centralized);
  }
  // Consistency where the EKF's assumptions hold (independent landmark pairs; the joint state keeps the
  // robot-robot correlations). The interlaced robot pairs of the per-agent filter ignore them and make
  // it overconfident (NEES printed above, not asserted).
  for (const auto& [name, runs] : {std::pair{"pose_ekf landmarks only", landmark_only_runs},
                                   std::pair{"centralized", centralized_runs}}) {
    const NeesCheck check = nees_check(runs);
    std::printf("%s: mean NEES %.3f, %.1f %% of steps in the 95 %% band [%.2f, %.2f]\n", name, check.mean,
                100.0 * check.inside, check.lower, check.upper);
    EXPECT_GT(check.mean, check.lower) << name;
    EXPECT_LT(check.mean, check.upper) << name;
    EXPECT_GT(check.inside, 0.85) << name;
  }
}

TEST(PoseFilters, CentralizedIsAtLeastAsAccurateWhenRobotMeasurementsMatter) {
  for (const unsigned seed : {4U, 5U, 6U}) {
    const WorldConfig c = few_landmarks(seed);
    const World world = simulate(c);
    const RunStats distributed = run_distributed<PoseEkf>(c, world);
    const RunStats landmarks_only = run_distributed<PoseEkf>(c, world, /*use_peers=*/false);
    const RunStats centralized = run_centralized(c, world);
    std::printf(
        "seed %u: centralized RMSE %.4f m (NEES %.2f), pose_ekf %.4f m (NEES %.2f), "
        "pose_ekf without robot pairs %.4f m\n",
        seed, centralized.rmse_last_half_m, centralized.mean_nees, distributed.rmse_last_half_m,
        distributed.mean_nees, landmarks_only.rmse_last_half_m);
    EXPECT_TRUE(centralized.covariances_ok);
    EXPECT_TRUE(distributed.covariances_ok);
    // The robot pairs matter: without them the distributed filter is much worse...
    EXPECT_GT(landmarks_only.rmse_last_half_m, 1.5 * distributed.rmse_last_half_m) << "seed " << seed;
    // ...and the joint filter, which keeps the cross-covariances, does at least as well.
    EXPECT_LE(centralized.rmse_last_half_m, 1.05 * distributed.rmse_last_half_m) << "seed " << seed;
  }
}

// ---- (b) information form == Kalman form ----

TEST(PoseFilters, IeifEqualsEkfOnASequenceOfSteps) {
  for (const double gate : {0.0, 9.21}) {
    WorldConfig c = landmark_rich(7);
    c.steps = 300;
    const World world = simulate(c);
    KalmanFilterParams params = params_for(c);
    params.range_bearing_gate_chi2 = gate;
    // Robot 0 twice, fed the same batches and the same peer messages (from a PoseEkf network).
    std::vector<std::unique_ptr<PoseEkf>> network;
    Inbox inbox;
    for (const AgentSetup& setup : world.setups) {
      network.push_back(std::make_unique<PoseEkf>(setup, params));
      inbox.states.push_back(Received<StateMessage>{setup.id, -1, *network.back()->initial_outbox().state});
    }
    PoseIeif ieif(world.setups[0], params);
    double max_mean_diff = 0.0;
    double max_cov_diff = 0.0;
    int updates = 0;
    int gated = 0;
    for (int k = 0; k < c.steps; ++k) {
      const auto& batches = world.batches[static_cast<std::size_t>(k)];
      // Every 10th step without a batch: prediction only (Q_pos random walk).
      const bool skip = k % 10 == 9;
      const StepInput input{k, skip ? nullptr : &batches[0], &inbox};
      const StepOutput b = ieif.step(input);
      Inbox next;
      for (std::size_t i = 0; i < network.size(); ++i) {
        const StepOutput out = network[i]->step(i == 0 ? input : StepInput{k, &batches[i], &inbox});
        if (i == 0) {
          EXPECT_EQ(out.diagnostics.neighbours_used, b.diagnostics.neighbours_used);
          EXPECT_EQ(out.diagnostics.ranges_gated, b.diagnostics.ranges_gated);
          EXPECT_EQ(out.diagnostics.updated, b.diagnostics.updated);
          updates += out.diagnostics.updated ? 1 : 0;
          gated += out.diagnostics.ranges_gated;
          EXPECT_MATRIX_NEAR(out.outbox.state->covariance, b.outbox.state->covariance, 1e-9);
        }
        next.states.push_back(Received<StateMessage>{static_cast<AgentId>(i), k, *out.outbox.state});
      }
      inbox = next;
      const Pose diff = pose_error(ieif.pose(), network[0]->pose());
      max_mean_diff = std::max(max_mean_diff, diff.cwiseAbs().maxCoeff());
      max_cov_diff =
          std::max(max_cov_diff, (ieif.covariance() - network[0]->covariance()).cwiseAbs().maxCoeff());
      ASSERT_LE(diff.cwiseAbs().maxCoeff(), 1e-9) << "step " << k;
      ASSERT_MATRIX_NEAR(ieif.covariance(), network[0]->covariance(), 1e-9);
    }
    std::printf("gate %.2f: %d updates, %d pairs gated, max |Δmean| %.2e, max |ΔP| %.2e\n", gate, updates,
                gated, max_mean_diff, max_cov_diff);
    EXPECT_GT(updates, 200);
  }
}

// The estimate carries the heading and its covariance row (the ROS 2 pose's orientation and yaw
// covariance, docs/ros2.md); position-only estimators leave it empty.
TEST(PoseFilters, EstimateCarriesTheHeadingAndItsCovarianceRow) {
  WorldConfig c = landmark_rich(7);
  c.steps = 20;
  const World world = simulate(c);
  const KalmanFilterParams params = params_for(c);
  PoseEkf ekf(world.setups[0], params);
  PoseIeif ieif(world.setups[0], params);
  DeadReckoning dead_reckoning(world.setups[0], params);
  const Inbox inbox;
  for (int k = 0; k < c.steps; ++k) {
    const StepInput input{k, &world.batches[static_cast<std::size_t>(k)][0], &inbox};
    ekf.step(input);
    ieif.step(input);
    dead_reckoning.step(input);
  }
  auto expect_heading = [](const Estimate& estimate, const Pose& pose, const Mat3& covariance) {
    ASSERT_TRUE(estimate.heading.has_value());
    EXPECT_EQ(estimate.heading->heading_rad, pose.z());
    EXPECT_EQ(estimate.heading->variance_rad2, covariance(2, 2));
    EXPECT_EQ(estimate.heading->position_cov_m_rad.x(), covariance(0, 2));
    EXPECT_EQ(estimate.heading->position_cov_m_rad.y(), covariance(1, 2));
    EXPECT_NE(covariance(0, 2), 0.0);  // the steps correlated heading and position
  };
  expect_heading(ekf.estimate(), ekf.pose(), ekf.covariance());
  expect_heading(ieif.estimate(), ieif.pose(), ieif.covariance());
  expect_heading(dead_reckoning.estimate(), dead_reckoning.pose(), dead_reckoning.covariance());
  const auto position_only = testing::make_named_estimator("ieif", world.setups[0], params);
  EXPECT_FALSE(position_only->estimate().heading.has_value());
}

// ---- Kernels ----

TEST(PoseFilters, ComposedOdometryEqualsSegmentBySegmentPrediction) {
  const Pose x0(1.0, -2.0, 3.0);
  Mat3 P = Mat3::Identity() * 0.01;
  P(0, 2) = P(2, 0) = 0.003;
  MeasurementBatch batch;
  batch.odometry = OdometryInput{{{0.3, 0.5, 0.1}, {0.2, -1.0, 0.25}, {0.4, 0.0, 0.1}}, 0.05, 0.02};
  const PosePropagation composed = propagate_pose(x0, &batch, KalmanFilterParams{});
  Pose x = x0;
  Mat3 P_seq = P;
  for (const OdometrySegment& s : batch.odometry->segments) {
    const models::UnicycleStep step = models::unicycle_step(x, s.v_mps * s.dt_s, s.omega_radps * s.dt_s);
    P_seq = step.F * P_seq * step.F.transpose() + models::unicycle_process_noise(step.G, 0.05, 0.02, s.dt_s);
    x = step.pose;
  }
  EXPECT_EQ(composed.segments_used, 3);
  EXPECT_EQ(composed.segments_skipped, 0);
  EXPECT_MATRIX_NEAR(composed.pose, x, 1e-15);
  EXPECT_MATRIX_NEAR((composed.F * P * composed.F.transpose() + composed.Q).eval(), P_seq, 1e-15);
  EXPECT_NEAR(composed.pose.z(), models::wrap_angle(3.0 + 0.05 - 0.25), 1e-15);  // wrapped past +π

  // No odometry: the pose stays, Q = Q_pos on (x, y) only.
  KalmanFilterParams params;
  params.process_noise_std_m = 0.1;
  const PosePropagation still = propagate_pose(x0, nullptr, params);
  EXPECT_MATRIX_NEAR(still.pose, x0, 0.0);
  EXPECT_MATRIX_NEAR(still.F, Mat3::Identity().eval(), 0.0);
  EXPECT_MATRIX_NEAR(still.Q, Eigen::Vector3d(0.01, 0.01, 0.0).asDiagonal().toDenseMatrix().eval(), 1e-15);
}

TEST(PoseFilters, LinearizationFoldsTheTargetCovarianceAndWrapsTheBearing) {
  const Pose pose(1.0, 0.0, 0.05);  // the target is behind: body bearing ≈ −π + 0.05
  RangeBearingTarget target;
  target.landmark = true;
  target.target_m = Vec2(-2.0, -0.3);  // global bearing ≈ −π + 0.1
  target.target_cov = Mat2{{0.04, 0.01}, {0.01, 0.09}};
  target.noise = Mat2{{0.01, 0.0}, {0.0, 0.0004}};
  const auto h = models::range_bearing(pose, target.target_m);
  ASSERT_LT(h->value.y(), -kPi + 0.06);
  target.measured = Vec2(h->value.x() + 0.1, models::wrap_angle(h->value.y() - 0.1));  // ≈ π − 0.05
  RangeBearingTarget at_robot = target;
  at_robot.target_m = pose.head<2>();  // no direction: skipped
  const RangeBearingRows rows = linearize_range_bearings(pose, {at_robot, target});
  EXPECT_EQ(rows.skipped, 1);
  ASSERT_EQ(rows.pairs(), 1);
  EXPECT_MATRIX_NEAR(rows.H, MatX(h->d_pose), 0.0);
  EXPECT_NEAR(rows.innovation(0), 0.1, 1e-12);
  EXPECT_NEAR(rows.innovation(1), -0.1, 1e-12);  // not 2π − 0.1
  const Mat2 expected = target.noise + h->d_target * target.target_cov * h->d_target.transpose();
  EXPECT_MATRIX_NEAR(rows.noise[0], expected, 1e-15);
  EXPECT_GT(rows.noise[0](1, 1), 2.0 * target.noise(1, 1));  // the landmark's uncertainty matters here
}

// ---- sightings taken before the end of their step (RangeBearingMeasurement::age_s) ----

OdometryInput turning_tail() {
  return OdometryInput{{{0.3, 1.0, 0.04}, {0.25, 1.5, 0.03}, {0.2, 0.5, 0.03}}, 0.01, 0.04};
}

TEST(PoseFilters, ARewoundPoseDrivenThroughTheTailIsTheStepsEndAndItsJacobianIsRight) {
  const OdometryInput odometry = turning_tail();
  const Pose end(1.0, -2.0, 3.0);
  const double age_s = 0.05;  // the last segment and 0.02 s of the one before
  const RewoundPose at = rewind_pose(end, &odometry, age_s);
  Pose forward = at.pose;
  forward = models::unicycle_step(forward, 0.25 * 0.02, 1.5 * 0.02).pose;
  forward = models::unicycle_step(forward, 0.2 * 0.03, 0.5 * 0.03).pose;
  EXPECT_LT((forward.head<2>() - end.head<2>()).norm(), 1e-12);
  EXPECT_NEAR(models::wrap_angle(forward.z() - end.z()), 0.0, 1e-12);
  for (int k = 0; k < 3; ++k) {
    const double eps = 1e-6;
    Pose plus = end;
    Pose minus = end;
    plus(k) += eps;
    minus(k) -= eps;
    Pose diff = rewind_pose(plus, &odometry, age_s).pose - rewind_pose(minus, &odometry, age_s).pose;
    diff.z() = models::wrap_angle(diff.z());
    EXPECT_LT((diff / (2 * eps) - at.d_end.col(k)).norm(), 1e-7) << "column " << k;
  }
  // Older than the step: the whole step is undone; no odometry or no age: the end itself.
  const RewoundPose whole = rewind_pose(end, &odometry, 1.0);
  EXPECT_LT((whole.pose - rewind_pose(end, &odometry, 0.1).pose).norm(), 1e-12);
  EXPECT_EQ(rewind_pose(end, nullptr, age_s).pose, end);
  EXPECT_EQ(rewind_pose(end, &odometry, 0.0).pose, end);
}

TEST(PoseFilters, ASightingIsSeenFromWhereTheRobotWasWhenItWasTaken) {
  const OdometryInput odometry = turning_tail();
  const Pose end(0.5, 0.5, 0.7);
  const double age_s = 0.06;
  const Pose then = rewind_pose(end, &odometry, age_s).pose;
  const Vec2 landmark(3.0, 2.0);
  const auto h = models::range_bearing(then, landmark);
  ASSERT_TRUE(h.has_value());
  RangeBearingTarget target;
  target.landmark = true;
  target.target_m = landmark;
  target.measured = h->value;
  target.noise = Vec2(0.01, 1e-4).asDiagonal();
  target.age_s = age_s;
  const RangeBearingRows rows = linearize_range_bearings(end, {target}, &odometry);
  ASSERT_EQ(rows.pairs(), 1);
  EXPECT_LT(rows.innovation.norm(), 1e-12);  // the exact sighting fits exactly
  target.age_s = 0.0;                        // as if taken at the step's end: the turn shows as error
  EXPECT_GT(std::abs(linearize_range_bearings(end, {target}, &odometry).innovation(1)), 0.02);
}

TEST(PoseFilters, GateDropsAnOutlierPairAndCountsIt) {
  // A robot at the origin facing +x sees four landmarks; one bearing is off by 0.5 rad (σ = 0.02).
  const std::vector<Vec2> landmarks = {Vec2(3.0, 0.0), Vec2(0.0, 3.0), Vec2(-3.0, 0.0), Vec2(0.0, -3.0)};
  MeasurementBatch batch;
  for (std::size_t l = 0; l < landmarks.size(); ++l) {
    RangeBearingMeasurement m;
    m.landmark = true;
    m.landmark_m = landmarks[l];
    const auto h = models::range_bearing(Pose::Zero(), landmarks[l]);
    m.range_m = h->value.x();
    m.bearing_rad = h->value.y() + (l == 1 ? 0.5 : 0.0);
    m.range_std_m = 0.05;
    m.bearing_std_rad = 0.02;
    batch.range_bearings.push_back(m);
  }
  for (const double gate : {0.0, 13.8}) {
    KalmanFilterParams params;
    params.initial_std_m = 0.05;
    params.initial_heading_std_rad = 0.02;
    params.range_bearing_gate_chi2 = gate;
    PoseEkf ekf(AgentSetup{}, params);
    const StepOutput out = ekf.step(StepInput{0, &batch, nullptr});
    EXPECT_EQ(out.diagnostics.ranges_gated, gate > 0.0 ? 1 : 0);
    EXPECT_EQ(out.diagnostics.neighbours_used, gate > 0.0 ? 3 : 4);
    if (gate > 0.0) {
      EXPECT_NEAR(ekf.heading_rad(), 0.0, 1e-12);  // the three good pairs agree with the prior exactly
    } else {
      EXPECT_GT(std::abs(ekf.heading_rad()), 0.01);  // the outlier pulls the heading
    }
  }
}

TEST(PoseFilters, GateDropsALoneMisreadSightingButTrustsTwoThatAgree) {
  // A robot at the origin facing +x, σ = (0.05 m, 0.02 rad). A misread barcode: a sighting 0.5 rad off
  // its landmark, alone in its step. Then two sightings that both say the heading is off by 0.5 rad:
  // the prediction is what is off, and both are kept.
  const auto sighting = [](const Vec2& landmark, double bearing_error_rad) {
    RangeBearingMeasurement m;
    m.landmark = true;
    m.landmark_m = landmark;
    const auto h = models::range_bearing(Pose::Zero(), landmark);
    m.range_m = h->value.x();
    m.bearing_rad = h->value.y() + bearing_error_rad;
    m.range_std_m = 0.05;
    m.bearing_std_rad = 0.02;
    return m;
  };
  KalmanFilterParams params;
  params.initial_std_m = 0.05;
  params.initial_heading_std_rad = 0.02;
  params.range_bearing_gate_chi2 = 13.8;

  MeasurementBatch lone;
  lone.range_bearings = {sighting(Vec2(3.0, 0.0), 0.5)};
  PoseEkf first(AgentSetup{}, params);
  const StepOutput dropped = first.step(StepInput{0, &lone, nullptr});
  EXPECT_EQ(dropped.diagnostics.ranges_gated, 1);
  EXPECT_NEAR(first.heading_rad(), 0.0, 1e-12);

  MeasurementBatch agreeing;
  agreeing.range_bearings = {sighting(Vec2(3.0, 0.0), 0.5), sighting(Vec2(0.0, 3.0), 0.5)};
  PoseEkf second(AgentSetup{}, params);
  const StepOutput kept = second.step(StepInput{0, &agreeing, nullptr});
  EXPECT_EQ(kept.diagnostics.ranges_gated, 0);
  EXPECT_EQ(kept.diagnostics.neighbours_used, 2);
  EXPECT_LT(second.heading_rad(), -0.1);  // both pull the heading toward the turn they agree on
}
// ---- (c) covariances stay symmetric PSD (also checked after every step in (a)) ----

TEST(PoseFilters, CovariancesSymmetricPositiveAfterEveryStep) {
  WorldConfig c = few_landmarks(8);
  c.steps = 400;
  const World world = simulate(c);
  const RunStats ekf = run_distributed<PoseEkf>(c, world);
  const RunStats ieif = run_distributed<PoseIeif>(c, world);
  const RunStats dr = run_distributed<DeadReckoning>(c, world);
  const RunStats central = run_centralized(c, world);
  EXPECT_TRUE(ekf.covariances_ok);
  EXPECT_TRUE(ieif.covariances_ok);
  EXPECT_TRUE(dr.covariances_ok);
  EXPECT_TRUE(central.covariances_ok);
}

// ---- (d) hostile inputs ----

RangeBearingMeasurement landmark_pair(const Vec2& landmark, const Pose& truth) {
  RangeBearingMeasurement m;
  m.landmark = true;
  m.landmark_m = landmark;
  const auto h = models::range_bearing(truth, landmark);
  m.range_m = h->value.x();
  m.bearing_rad = h->value.y();
  m.range_std_m = 0.1;
  m.bearing_std_rad = 0.05;
  return m;
}

MeasurementBatch hostile_batch() {
  const Pose truth(0.5, 0.2, 0.1);
  MeasurementBatch batch;
  batch.world_step = 0;
  batch.range_bearings.push_back(landmark_pair(Vec2(4.0, 1.0), truth));   // good
  batch.range_bearings.push_back(landmark_pair(Vec2(-2.0, 3.0), truth));  // good
  auto bad = [&](auto mutate) {
    RangeBearingMeasurement m = landmark_pair(Vec2(1.0, -3.0), truth);
    mutate(m);
    batch.range_bearings.push_back(m);
  };
  bad([](auto& m) { m.range_m = kNaN; });
  bad([](auto& m) { m.bearing_rad = kNaN; });
  bad([](auto& m) { m.range_m = std::numeric_limits<double>::infinity(); });
  bad([](auto& m) { m.range_m = -1.0; });
  bad([](auto& m) { m.range_std_m = 0.0; });
  bad([](auto& m) { m.bearing_std_rad = 0.0; });
  bad([](auto& m) { m.range_std_m = -0.1; });
  bad([](auto& m) { m.bearing_std_rad = kNaN; });
  bad([](auto& m) { m.landmark_m.x() = kNaN; });
  bad([](auto& m) { m.landmark_cov(0, 0) = kNaN; });
  bad([](auto& m) { m.landmark_cov = Mat2{{1.0, 0.0}, {0.0, -1.0}}; });  // not PSD
  OdometryInput odometry;
  odometry.v_std = 0.05;
  odometry.omega_std = 0.05;
  odometry.segments = {{0.2, 0.1, 0.1},  {kNaN, 0.1, 0.1},    {0.2, kNaN, 0.1}, {0.2, 0.1, kNaN},
                       {0.2, 0.1, -0.1}, {1e300, 0.0, 1e300}, {0.2, 0.1, 0.1}};
  batch.odometry = odometry;
  return batch;
}
constexpr int kHostilePairs = 11;    // all but the two good ones
constexpr int kHostileSegments = 5;  // all but the first and last

template <typename Filter>
void expect_survives_hostile_inputs() {
  KalmanFilterParams params;
  params.initial_std_m = 1.0;
  Filter filter(AgentSetup{}, params);
  const MeasurementBatch batch = hostile_batch();
  for (std::int64_t k = 0; k < 3; ++k) {
    const StepOutput out = filter.step(StepInput{k, &batch, nullptr});
    EXPECT_TRUE(filter.pose().allFinite()) << filter.name();
    EXPECT_TRUE(filter.covariance().allFinite()) << filter.name();
    EXPECT_TRUE(out.outbox.state->mean_m.allFinite() && out.outbox.state->covariance.allFinite());
    EXPECT_EQ(filter.odometry_segments_skipped(), (k + 1) * kHostileSegments) << filter.name();
    if (filter.name() != "dead_reckoning") {
      EXPECT_EQ(out.diagnostics.neighbours_skipped, kHostilePairs) << filter.name();
      EXPECT_EQ(out.diagnostics.neighbours_used, 2) << filter.name();
      EXPECT_TRUE(out.diagnostics.updated);
    }
  }
  // Odometry with unusable noise densities: every segment skipped, the pose stays, P gains Q_pos.
  MeasurementBatch bad_noise;
  bad_noise.odometry = OdometryInput{{{0.3, 0.0, 1.0}, {0.3, 0.0, 1.0}}, kNaN, 0.05};
  const Pose before = filter.pose();
  const Mat3 P_before = filter.covariance();
  (void)filter.step(StepInput{3, &bad_noise, nullptr});
  EXPECT_EQ(filter.odometry_segments_skipped(), 3 * kHostileSegments + 2);
  EXPECT_MATRIX_NEAR(filter.pose(), before, 1e-12);
  const double q = params.process_noise_std_m * params.process_noise_std_m;
  EXPECT_NEAR(filter.covariance()(0, 0), P_before(0, 0) + q, 1e-9);
  EXPECT_NEAR(filter.covariance()(2, 2), P_before(2, 2), 1e-9);
}

TEST(PoseFilters, HostileInputsAreSkippedCountedAndNeverPoisonTheState) {
  expect_survives_hostile_inputs<PoseEkf>();
  expect_survives_hostile_inputs<PoseIeif>();
  expect_survives_hostile_inputs<DeadReckoning>();
}

TEST(PoseFilters, CentralizedSurvivesHostileInputs) {
  KalmanFilterParams params;
  params.initial_std_m = 1.0;
  AgentSetup a;
  a.id = 3;
  AgentSetup b;
  b.id = 8;
  b.initial_guess_m = Vec2(3.0, 0.0);
  CentralizedPoseEkf filter({a, b}, params);
  MeasurementBatch batch = hostile_batch();
  RangeBearingMeasurement to_unknown = landmark_pair(Vec2(3.0, 0.0), Pose::Zero());
  to_unknown.landmark = false;
  to_unknown.peer = 42;  // not a robot of this filter
  batch.range_bearings.push_back(to_unknown);
  to_unknown.peer = 3;  // itself
  batch.range_bearings.push_back(to_unknown);
  to_unknown.peer = 8;  // robot b: used
  batch.range_bearings.push_back(to_unknown);
  filter.step({&batch, nullptr});
  EXPECT_TRUE(filter.state().allFinite());
  EXPECT_TRUE(core::is_symmetric_psd_dynamic(filter.covariance(), 1e-12));
  EXPECT_EQ(filter.odometry_segments_skipped(), kHostileSegments);
  EXPECT_EQ(filter.last_diagnostics().neighbours_skipped, kHostilePairs + 2);
  EXPECT_EQ(filter.last_diagnostics().neighbours_used, 3);
  EXPECT_THROW(filter.step({&batch}), std::invalid_argument);
  EXPECT_FALSE(filter.estimate(5).valid);
  EXPECT_THROW((void)filter.pose(5), std::invalid_argument);
}

// ---- (e) robot peers and their messages ----

Received<StateMessage> peer_state(AgentId sender, std::int64_t step, const Vec2& mean, const Mat2& cov) {
  Received<StateMessage> r;
  r.sender = sender;
  r.sender_step = step;
  r.message.mean_m = mean;
  r.message.covariance = cov;
  return r;
}

RangeBearingMeasurement peer_pair(AgentId peer, const Pose& from, const Vec2& to) {
  RangeBearingMeasurement m = landmark_pair(to, from);
  m.landmark = false;
  m.landmark_m = Vec2::Zero();
  m.peer = peer;
  return m;
}

TEST(PoseFilters, PeerWithoutAUsableMessageIsSkippedAndCounted) {
  const Pose self(0.0, 0.0, 0.0);
  MeasurementBatch batch;
  batch.range_bearings = {peer_pair(1, self, Vec2(3.0, 0.0)), peer_pair(2, self, Vec2(0.0, 3.0)),
                          peer_pair(3, self, Vec2(-3.0, 0.0)), peer_pair(4, self, Vec2(0.0, -3.0)),
                          peer_pair(0, self, Vec2(1.0, 1.0))};  // itself
  Inbox inbox;
  inbox.states = {peer_state(1, 0, Vec2(3.0, 0.0), 0.01 * Mat2::Identity()),
                  peer_state(1, 2, Vec2(3.0, 0.0), 0.01 * Mat2::Identity()),  // newer sample of 1
                  peer_state(3, 2, Vec2(kNaN, 0.0), 0.01 * Mat2::Identity()),
                  peer_state(4, 2, Vec2(0.0, -3.0), 1e7 * Mat2::Identity()),  // trace above the limit
                  peer_state(0, 2, Vec2(0.0, 0.0), 0.01 * Mat2::Identity())};
  // Peer 2 has no message at all.
  KalmanFilterParams params;
  params.initial_std_m = 0.5;
  PoseEkf ekf(AgentSetup{}, params);
  const StepOutput out = ekf.step(StepInput{3, &batch, &inbox});
  EXPECT_EQ(out.diagnostics.neighbours_used, 1);
  EXPECT_EQ(out.diagnostics.neighbours_skipped, 4);
  EXPECT_TRUE(out.diagnostics.updated);

  // The used peer: its message is one step old (a = 1), so its covariance gains Q_pos once.
  const RangeBearingSelection selection = collect_range_bearings(StepInput{3, &batch, &inbox}, 0, params);
  ASSERT_EQ(selection.targets.size(), 1U);
  const double q = params.process_noise_std_m * params.process_noise_std_m;
  EXPECT_MATRIX_NEAR(selection.targets[0].target_cov, ((0.01 + q) * Mat2::Identity()).eval(), 1e-15);

  // No inbox at all: every robot pair is skipped; prediction only.
  PoseEkf alone(AgentSetup{}, params);
  const StepOutput none = alone.step(StepInput{0, &batch, nullptr});
  EXPECT_EQ(none.diagnostics.neighbours_used, 0);
  EXPECT_EQ(none.diagnostics.neighbours_skipped, 5);
  EXPECT_FALSE(none.diagnostics.updated);
}

TEST(PoseFilters, InterlacedPeerCovarianceWeakensTheUpdate) {
  // The same pair to a peer known exactly vs known to ±1 m: the uncertain peer moves the pose less.
  const Pose truth(0.0, 0.0, 0.0);
  MeasurementBatch batch;
  batch.range_bearings = {peer_pair(1, truth, Vec2(3.0, 1.0))};
  KalmanFilterParams params;
  params.initial_std_m = 1.0;
  params.inflate_stale = false;
  AgentSetup setup;
  setup.initial_guess_m = Vec2(0.5, -0.5);
  double gain[2];
  for (int which = 0; which < 2; ++which) {
    Inbox inbox;
    inbox.states = {peer_state(1, 0, Vec2(3.0, 1.0), (which == 0 ? 0.0 : 1.0) * Mat2::Identity())};
    PoseEkf ekf(setup, params);
    (void)ekf.step(StepInput{1, &batch, &inbox});
    gain[which] = (ekf.pose().head<2>() - setup.initial_guess_m).norm();
  }
  EXPECT_GT(gain[0], 1.5 * gain[1]);
}

TEST(PoseFilters, CentralizedOfOneRobotEqualsPoseEkfWithLandmarks) {
  WorldConfig c = landmark_rich(9);
  c.robots = 1;
  c.steps = 200;
  const World world = simulate(c);
  const KalmanFilterParams params = params_for(c);
  PoseEkf ekf(world.setups[0], params);
  CentralizedPoseEkf central(world.setups, params);
  for (int k = 0; k < c.steps; ++k) {
    const MeasurementBatch& batch = world.batches[static_cast<std::size_t>(k)][0];
    (void)ekf.step(StepInput{k, &batch, nullptr});
    central.step({&batch});
    ASSERT_LE(pose_error(central.pose(0), ekf.pose()).cwiseAbs().maxCoeff(), 1e-12) << "step " << k;
    ASSERT_MATRIX_NEAR(central.covariance(), MatX(ekf.covariance()), 1e-12);
  }
  EXPECT_MATRIX_NEAR(central.estimate(0).covariance, ekf.estimate().covariance, 1e-12);
}

TEST(PoseFilters, CentralizedRobotPairInformsBothRobots) {
  // Robot 0 knows its pose well, robot 1 badly; only robot 0 measures robot 1. The joint update moves
  // and shrinks robot 1 (a per-agent filter at robot 1 would learn nothing from robot 0's pair).
  KalmanFilterParams params;
  params.initial_std_m = 1.0;
  params.initial_heading_std_rad = 0.01;
  AgentSetup a;
  a.id = 0;
  AgentSetup b;
  b.id = 1;
  b.initial_guess_m = Vec2(3.5, 0.5);  // truth (3, 0)
  CentralizedPoseEkf central({a, b}, params);
  MeasurementBatch batch_a;
  batch_a.range_bearings = {landmark_pair(Vec2(-3.0, 0.0), Pose::Zero()),
                            landmark_pair(Vec2(0.0, 3.0), Pose::Zero()),
                            peer_pair(1, Pose::Zero(), Vec2(3.0, 0.0))};
  central.step({&batch_a, nullptr});
  EXPECT_LT((central.pose(1).head<2>() - Vec2(3.0, 0.0)).norm(), 0.2);
  EXPECT_LT(central.estimate(1).covariance.trace(), 0.1);
  EXPECT_GT((central.covariance().block<3, 3>(0, 3).cwiseAbs().maxCoeff()), 1e-6);  // correlated now
}

TEST(PoseFilters, PublishesPositionBlockAndDegree) {
  KalmanFilterParams params;
  params.initial_std_m = 2.0;
  params.initial_heading_std_rad = 0.3;
  AgentSetup setup;
  setup.id = 5;
  setup.initial_guess_m = Vec2(1.0, 2.0);
  setup.initial_heading_rad = 3.0 * kPi;  // wrapped to π
  for (const char* name : {"pose_ekf", "pose_ieif", "dead_reckoning"}) {
    const auto estimator = testing::make_named_estimator(name, setup, params);
    const Outbox initial = estimator->initial_outbox();
    ASSERT_TRUE(initial.state.has_value());
    EXPECT_MATRIX_NEAR(initial.state->mean_m, setup.initial_guess_m, 0.0);
    EXPECT_MATRIX_NEAR(initial.state->covariance, (4.0 * Mat2::Identity()).eval(), 1e-12);
    EXPECT_FALSE(initial.state->anchor);
    EXPECT_TRUE(initial.state->active);
    EXPECT_EQ(initial.state->degree, 0);
    MeasurementBatch batch;
    batch.neighbours = {1, 2, 7};
    const StepOutput out = estimator->step(StepInput{0, &batch, nullptr});
    EXPECT_EQ(out.outbox.state->degree, 3) << name;
    const Estimate estimate = estimator->estimate();
    EXPECT_TRUE(estimate.valid);
    // No odometry: Q_pos on the position.
    const double q = params.process_noise_std_m * params.process_noise_std_m;
    EXPECT_MATRIX_NEAR(estimate.covariance, ((4.0 + q) * Mat2::Identity()).eval(), 1e-12) << name;
  }
  PoseEkf ekf(setup, params);
  EXPECT_NEAR(ekf.heading_rad(), kPi, 1e-12);
  EXPECT_NEAR(ekf.covariance()(2, 2), 0.09, 1e-15);
}

}  // namespace
}  // namespace swarmloc::estimators
