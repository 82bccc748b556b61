// TeamPoseEkf (estimators/pose/team_pose_ekf.hpp): the team's joint pose EKF at every robot from shared
// observations.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <memory>
#include <vector>

#include "pose_world.hpp"
#include "swarmloc/core/gaussian.hpp"
#include "swarmloc/estimators/pose/centralized_pose_ekf.hpp"
#include "swarmloc/estimators/pose/team_pose_ekf.hpp"

namespace swarmloc::estimators {
namespace {

using pose_world::params_for;
using pose_world::simulate;
using pose_world::World;
using pose_world::WorldConfig;

/// Landmarks at one side only: the robots far from them localize through each other's sightings, so the
/// joint filter's cross-covariances matter.
WorldConfig team_world(unsigned seed, int steps) {
  WorldConfig c;
  c.robots = 4;
  c.seed = seed;
  c.steps = steps;
  c.landmarks = {Vec2(4.0, 0.0), Vec2(4.0, 1.5)};
  c.landmark_radius_m = 3.0;
  c.robot_radius_m = 6.0;
  return c;
}

/// Whether robot `to` receives what robot `from` published after world step k.
using Delivery = std::function<bool(int from, int to, int k)>;

/// Every robot runs TeamPoseEkf in lockstep: step k sees what the others published after step k − 1
/// (the newest sample per sender that was delivered, as the runtime's mailbox keeps it).
struct TeamRun {
  TeamRun(const KalmanFilterParams& params, const World& world) : world_(world) {
    for (const AgentSetup& setup : world.setups) {
      robots.push_back(std::make_unique<TeamPoseEkf>(setup, params));
      published.push_back(*robots.back()->initial_outbox().observations);
    }
    inboxes.resize(robots.size());
  }

  void run(int steps, const Delivery& delivered) {
    const int n = static_cast<int>(robots.size());
    for (int k = 0; k < steps; ++k) {
      for (int to = 0; to < n; ++to) {
        Inbox& inbox = inboxes[static_cast<std::size_t>(to)];
        for (int from = 0; from < n; ++from) {
          if (from == to || !delivered(from, to, k)) continue;
          std::erase_if(inbox.observations, [&](const auto& r) { return r.sender == from; });
          inbox.observations.push_back({from, k - 1, published[static_cast<std::size_t>(from)]});
        }
      }
      for (int i = 0; i < n; ++i) {
        const auto at = static_cast<std::size_t>(i);
        const StepOutput out =
            robots[at]->step(StepInput{k, &world_.batches[static_cast<std::size_t>(k)][at], &inboxes[at]});
        published[at] = *out.outbox.observations;
      }
    }
  }

  const World& world_;
  std::vector<std::unique_ptr<TeamPoseEkf>> robots;
  std::vector<ObservationMessage> published;
  std::vector<Inbox> inboxes;
};

/// The centralized filter after world steps 0..last.
CentralizedPoseEkf centralized_through(const KalmanFilterParams& params, const World& world, int last) {
  CentralizedPoseEkf filter(world.setups, params);
  for (int k = 0; k <= last; ++k) {
    std::vector<const MeasurementBatch*> batches;
    for (const auto& batch : world.batches[static_cast<std::size_t>(k)]) batches.push_back(&batch);
    filter.step(batches);
  }
  return filter;
}

TEST(TeamPoseEkf, EveryRobotsSettledFilterIsTheCentralizedFilterStepForStep) {
  const WorldConfig config = team_world(3, 120);
  const World world = simulate(config);
  TeamRun team(params_for(config), world);
  team.run(config.steps, [](int, int, int) { return true; });
  const CentralizedPoseEkf reference = centralized_through(params_for(config), world, config.steps - 2);
  for (const auto& robot : team.robots) {
    // Lockstep: the others' data of the last step arrive with the next one.
    ASSERT_EQ(robot->settled_step(), config.steps - 2);
    ASSERT_EQ(robot->settled().ids(), reference.ids());
    EXPECT_EQ(robot->settled().state(), reference.state());
    EXPECT_EQ(robot->settled().covariance(), reference.covariance());
  }
}

TEST(TeamPoseEkf, WithCorrelatedSightingsTooEveryRobotsSettledFilterIsTheCentralizedFilter) {
  const WorldConfig config = team_world(17, 100);
  const World world = simulate(config);
  KalmanFilterParams params = params_for(config);
  params.sighting_correlation_time_s = 2.0;
  params.range_correlated_fraction = 0.9;
  params.bearing_correlated_fraction = 0.5;
  TeamRun team(params, world);
  team.run(config.steps, [](int, int, int) { return true; });
  const CentralizedPoseEkf reference = centralized_through(params, world, config.steps - 2);
  // The inflation changes the filter (a mutant that ignores it on either side fails the equality).
  ASSERT_GT(
      (reference.state() - centralized_through(params_for(config), world, config.steps - 2).state()).norm(),
      1e-6);
  for (const auto& robot : team.robots) {
    ASSERT_EQ(robot->settled_step(), config.steps - 2);
    EXPECT_EQ(robot->settled().state(), reference.state());
    EXPECT_EQ(robot->settled().covariance(), reference.covariance());
  }
}

TEST(SightingHistory, InflatesTheCorrelatedPartByTheGapSinceTheLastSightingOfThatTarget) {
  KalmanFilterParams params;
  params.sighting_correlation_time_s = 4.0;
  params.range_correlated_fraction = 0.9;
  params.bearing_correlated_fraction = 0.5;
  SightingHistory history;
  const Vec2 landmark(3.0, -1.0);
  const auto factor = [](double fraction, double gap_s) {
    const double rho = std::exp(-gap_s / 4.0);
    return (1.0 - fraction) + fraction * (1.0 + rho) / (1.0 - rho);
  };
  EXPECT_EQ(history.inflation(0, true, landmark, 10.0, params), Vec2(1.0, 1.0));  // first sighting
  const Vec2 after_one = history.inflation(0, true, landmark, 11.0, params);
  EXPECT_NEAR(after_one.x(), factor(0.9, 1.0), 1e-12);
  EXPECT_NEAR(after_one.y(), factor(0.5, 1.0), 1e-12);
  // The gap counts from the newest sighting of the same target, not the first.
  EXPECT_NEAR(history.inflation(0, true, landmark, 11.5, params).x(), factor(0.9, 0.5), 1e-12);
  // Another landmark, and a robot peer, have their own history.
  EXPECT_EQ(history.inflation(0, true, Vec2(3.0, 1.0), 11.5, params), Vec2(1.0, 1.0));
  EXPECT_EQ(history.inflation(2, false, Vec2::Zero(), 11.5, params), Vec2(1.0, 1.0));
  EXPECT_NEAR(history.inflation(2, false, Vec2::Zero(), 15.5, params).y(), factor(0.5, 4.0), 1e-12);
  // Independent sightings (τ = 0) are never inflated.
  params.sighting_correlation_time_s = 0.0;
  EXPECT_EQ(history.inflation(0, true, landmark, 11.6, params), Vec2(1.0, 1.0));
}

TEST(SightingHistory, LandmarksWithinTheClusterRadiusAreOneStream) {
  KalmanFilterParams params;
  params.sighting_correlation_time_s = 4.0;
  params.range_correlated_fraction = 0.9;
  params.bearing_correlated_fraction = 0.5;
  params.sighting_cluster_radius_m = 0.5;
  const double rho = std::exp(-0.2 / 4.0);
  const double repeat = 0.1 + 0.9 * (1.0 + rho) / (1.0 - rho);
  SightingHistory history;
  EXPECT_EQ(history.inflation(0, true, Vec2(3.0, -1.0), 10.0, params), Vec2(1.0, 1.0));
  // 0.3 m from it, 0.2 s later: a repeat of the same stream.
  EXPECT_NEAR(history.inflation(0, true, Vec2(3.3, -1.0), 10.2, params).x(), repeat, 1e-12);
  // 2 m away: a stream of its own.
  EXPECT_EQ(history.inflation(0, true, Vec2(5.0, -1.0), 10.4, params), Vec2(1.0, 1.0));
  // Without a radius, the landmark 0.3 m away is its own stream.
  params.sighting_cluster_radius_m = 0.0;
  SightingHistory separate;
  EXPECT_EQ(separate.inflation(0, true, Vec2(3.0, -1.0), 10.0, params), Vec2(1.0, 1.0));
  EXPECT_EQ(separate.inflation(0, true, Vec2(3.3, -1.0), 10.2, params), Vec2(1.0, 1.0));
}

TEST(TeamPoseEkf, SamplesLostInBurstsShorterThanTheShareWindowChangeNothing) {
  const WorldConfig config = team_world(5, 150);
  const World world = simulate(config);
  KalmanFilterParams team_params = params_for(config);
  team_params.team_share_spans = 8;
  team_params.team_wait_steps = 30;
  TeamRun team(team_params, world);
  // Each link loses runs of up to 6 samples in a row, a different pattern per link.
  team.run(config.steps, [](int from, int to, int k) { return k < 2 || (k + 3 * from + 5 * to) % 13 > 5; });
  // Every link delivers at least once in each 7 steps, so with 8 spans per sample nothing is missing.
  const CentralizedPoseEkf reference = centralized_through(params_for(config), world, config.steps - 8);
  for (const auto& robot : team.robots) {
    ASSERT_GE(robot->settled_step(), config.steps - 8);
    const CentralizedPoseEkf at =
        centralized_through(params_for(config), world, static_cast<int>(robot->settled_step()));
    EXPECT_EQ(robot->settled().state(), at.state());
  }
}

TEST(TeamPoseEkf, MatchesTheCentralizedEstimateAndStaysConsistentWithoutOnePeer) {
  const WorldConfig config = team_world(7, 200);
  const World world = simulate(config);
  KalmanFilterParams team_params = params_for(config);
  team_params.team_wait_steps = 10;
  TeamRun team(team_params, world);
  // Robot 3 falls silent after step 50: the others wait wait_steps, then step without its data.
  team.run(config.steps, [](int from, int, int k) { return from != 3 || k < 50; });
  for (int i = 0; i < 3; ++i) {
    const TeamPoseEkf& robot = *team.robots[static_cast<std::size_t>(i)];
    EXPECT_EQ(robot.settled_step(), config.steps - 1 - team_params.team_wait_steps) << "robot " << i;
    const Estimate estimate = robot.estimate();
    ASSERT_TRUE(estimate.valid);
    ASSERT_TRUE(estimate.heading.has_value());
    EXPECT_TRUE(core::is_symmetric_psd_dynamic(robot.settled().covariance(), 1e-12));
    const Vec2 error = estimate.mean_m - world.truth.back()[static_cast<std::size_t>(i)].head<2>();
    // 3σ of its own covariance plus 1 cm: the estimate knows how good it is.
    EXPECT_LT(error.norm(), 3.0 * std::sqrt(estimate.covariance.trace()) + 0.01) << "robot " << i;
  }
}

TEST(TeamPoseEkf, APeerHeardLateJoinsWithItsOwnEstimateBroughtForwardThroughItsSpans) {
  const WorldConfig config = team_world(11, 102);
  const World world = simulate(config);
  KalmanFilterParams team_params = params_for(config);
  team_params.team_share_spans = 40;
  team_params.team_wait_steps = 5;
  TeamRun team(team_params, world);
  // Nobody hears robot 2 before step 100: its first sample starts at its estimate of step 59, and the
  // others' settled filters are near step 94 by then. It must enter where it is at step 94, not at 59.
  team.run(config.steps, [](int from, int, int k) { return from != 2 || k >= 100; });
  const TeamPoseEkf& robot = *team.robots[0];
  ASSERT_EQ(robot.settled().ids().size(), 4U);
  EXPECT_EQ(robot.settled().ids().back(), 2);  // joined last, after the step-by-step start
  const auto step = static_cast<std::size_t>(robot.settled_step());
  const Vec2 moved = world.truth[step][2].head<2>() - world.truth[59][2].head<2>();
  ASSERT_GT(moved.norm(), 1.0);  // the test world: far enough for a wrong join to show
  const Vec2 error = robot.settled().pose(2).head<2>() - world.truth[step][2].head<2>();
  const Mat3 covariance = robot.settled().pose_covariance(2);
  EXPECT_LT(error.norm(), 3.0 * std::sqrt(covariance.topLeftCorner<2, 2>().trace()) + 0.01);
}

TEST(TeamPoseEkf, EachSampleCarriesItsNewestSpansAndTheEstimateJustBeforeThem) {
  const WorldConfig config = team_world(13, 30);
  const World world = simulate(config);
  KalmanFilterParams team_params = params_for(config);
  team_params.team_share_spans = 4;
  TeamRun team(team_params, world);
  const ObservationMessage first = team.published[0];
  EXPECT_EQ(first.origin_step, -1);
  EXPECT_TRUE(first.spans.empty());
  team.run(config.steps, [](int, int, int) { return true; });
  const ObservationMessage& last = team.published[0];
  ASSERT_EQ(last.spans.size(), 4U);
  EXPECT_EQ(last.origin_step, config.steps - 5);
  for (std::size_t k = 0; k < last.spans.size(); ++k) {
    EXPECT_EQ(last.spans[k].first_world_step, config.steps - 4 + static_cast<int>(k));
    EXPECT_EQ(last.spans[k].world_step, last.spans[k].first_world_step);
  }
  EXPECT_TRUE(core::is_symmetric_psd_dynamic(last.origin_covariance, 1e-12));
}

TEST(TeamPoseEkf, RejectsParametersThatCannotWork) {
  const WorldConfig config = team_world(1, 1);
  const World world = simulate(config);
  KalmanFilterParams no_spans = params_for(config);
  no_spans.team_share_spans = 0;
  EXPECT_THROW(TeamPoseEkf(world.setups[0], no_spans), std::invalid_argument);
}

}  // namespace
}  // namespace swarmloc::estimators
