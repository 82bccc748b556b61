// 3-D worlds (world.dimensions: 3): placement in the box, anchors at spread heights, the disk graph and the
// ranges in space, what each agent is told, the scenario rules, and scoring in space.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/world/metrics.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::world {
namespace {

const std::string kScenarioFolder3d = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/";

config::Scenario scenario_3d(std::vector<std::string> overrides = {}) {
  return config::load_scenario(kScenarioFolder3d + "default3d.yaml", overrides);
}

TEST(World3d, AgentsFillTheBoxAndAnchorsSitAtSpreadHeights) {
  const auto scenario = scenario_3d();
  const World world = build_world(scenario);
  ASSERT_EQ(world.dimensions, 3);
  ASSERT_EQ(world.altitude.size(), world.truth.size());
  const double height = scenario.world.height_m;
  std::vector<double> anchor_heights;
  double lowest = height;
  double highest = 0.0;
  for (AgentId i = 0; i < world.size(); ++i) {
    const double z = world.altitude[static_cast<std::size_t>(i)];
    EXPECT_GE(z, 0.0);
    EXPECT_LE(z, height);
    lowest = std::min(lowest, z);
    highest = std::max(highest, z);
    if (world.is_anchor[static_cast<std::size_t>(i)]) anchor_heights.push_back(z);
  }
  EXPECT_GT(highest - lowest, 0.5 * height) << "z must be drawn over the box, not left at 0";
  ASSERT_EQ(anchor_heights.size(), 8U);
  for (std::size_t k = 0; k < anchor_heights.size(); ++k)
    EXPECT_DOUBLE_EQ(anchor_heights[k], height * (static_cast<double>(k) + 0.5) / 8.0);
}

TEST(World3d, NeighboursAreThoseWithinTheRadiusInSpace) {
  const auto scenario =
      scenario_3d({"world.height_m=30", "world.require_connected=false", "world.require_localizable=false"});
  const World world = build_world(scenario);
  int planar_only = 0;
  for (AgentId i = 0; i < world.size(); ++i) {
    const auto& heard = world.neighbours[static_cast<std::size_t>(i)];
    for (AgentId j = 0; j < world.size(); ++j) {
      if (j == i) continue;
      const bool within = world.distance(i, j) <= scenario.world.comm_radius_m;
      EXPECT_EQ(std::binary_search(heard.begin(), heard.end(), j), within) << i << "-" << j;
      const double planar =
          (world.truth[static_cast<std::size_t>(i)] - world.truth[static_cast<std::size_t>(j)]).norm();
      if (!within && planar <= scenario.world.comm_radius_m) ++planar_only;
    }
  }
  EXPECT_GT(planar_only, 0) << "a 30 m high box must separate some pairs that are close in the plane";
}

TEST(World3d, NoiselessRangesAreTheDistancesInSpace) {
  const auto scenario = scenario_3d({"noise.range_std_m=0"});
  const World world = build_world(scenario);
  for (AgentId i = 0; i < world.size(); ++i) {
    const auto batch = generate_batch(world, scenario, i, 5);
    ASSERT_EQ(batch.ranges.size(), world.neighbours[static_cast<std::size_t>(i)].size());
    for (const auto& range : batch.ranges) {
      const Vec3 offset = world.position3(i) - world.position3(range.peer);
      EXPECT_NEAR(range.range_m, offset.norm(), 1e-12) << i << "-" << range.peer;
    }
  }
}

TEST(World3d, AnAnchorsFixCarriesItsZ) {
  const auto scenario = scenario_3d();
  const World world = build_world(scenario);
  int fixes = 0;
  for (AgentId i = 0; i < world.size(); ++i) {
    const auto batch = generate_batch(world, scenario, i, 5);
    const auto k = static_cast<std::size_t>(i);
    ASSERT_EQ(batch.fix.has_value(), static_cast<bool>(world.is_anchor[k])) << i;
    if (!batch.fix) continue;
    ASSERT_TRUE(batch.fix->z_m.has_value()) << i;
    EXPECT_EQ(*batch.fix->z_m, world.altitude[k]) << "exact anchors: the fix is the truth";
    ++fixes;
  }
  EXPECT_EQ(fixes, world.anchor_count());
}

TEST(World3d, EachAgentIsToldItsZAndTheWorldsDimension) {
  const auto scenario = scenario_3d({"world.initial_guess_std_m=1.5"});
  const World world = build_world(scenario, 3);
  double squared = 0.0;
  int unknowns = 0;
  for (AgentId i = 0; i < world.size(); ++i) {
    const auto setup = world.setup_of(i);
    EXPECT_EQ(setup.dimensions, 3);
    const auto k = static_cast<std::size_t>(i);
    if (world.is_anchor[k]) {
      EXPECT_EQ(setup.initial_altitude_m, world.altitude[k]);
      continue;
    }
    squared += std::pow(setup.initial_altitude_m - world.altitude[k], 2);
    ++unknowns;
  }
  // 22 draws of N(0, 1.5²): their RMS lies in [0.5, 3] for any seed (a 0 means z was not drawn).
  const double rms = std::sqrt(squared / unknowns);
  EXPECT_GT(rms, 0.5);
  EXPECT_LT(rms, 3.0);
}

TEST(World3d, APlanarWorldHasNoZ) {
  const auto scenario = config::load_scenario(kScenarioFolder3d + "default.yaml");
  const World world = build_world(scenario);
  EXPECT_EQ(world.dimensions, 2);
  EXPECT_TRUE(world.altitude.empty());
  EXPECT_EQ(world.setup_of(0).dimensions, 2);
  EXPECT_EQ(world.distance(0, 1), (world.truth[0] - world.truth[1]).norm());
}

TEST(World3d, ScenarioRulesKeepThreeDimensionsToWhatRunsInThem) {
  EXPECT_NO_THROW(scenario_3d());
  for (const auto& bad : std::vector<std::vector<std::string>>{{"world.dimensions=4"},
                                                               {"algorithm.name=ieif"},
                                                               {"world.placement=grid"},
                                                               {"world.height_m=0"},
                                                               {"world.motion=random_walk"}}) {
    EXPECT_THROW(scenario_3d(bad), config::ScenarioError) << bad.front();
  }
  // Truth moves in space for the fusion-centre filters, which predict with process noise.
  for (const std::string algorithm : {"ekf", "lbekf", "lbekf_vr", "lbekf_i"})
    EXPECT_NO_THROW(scenario_3d({"algorithm.name=" + algorithm, "world.motion=random_walk"})) << algorithm;
}

estimators::Estimate spatial_estimate(const Vec3& mean, const Mat3& covariance) {
  estimators::Estimate estimate;
  estimate.mean_m = mean.head<2>();
  estimate.covariance = covariance.topLeftCorner<2, 2>();
  estimate.altitude = altitude_of(mean, covariance);
  estimate.valid = true;
  return estimate;
}

TEST(World3dScore, ErrorsAndNeesAreInSpace) {
  const std::vector<Vec2> truth{Vec2(0, 0), Vec2(10, 0), Vec2(0, 10)};
  const std::vector<double> truth_z{1.0, 2.0, 3.0};
  const std::vector<bool> is_anchor{true, false, false};
  Mat3 covariance;
  covariance << 0.04, 0.01, 0.02, 0.01, 0.09, 0.0, 0.02, 0.0, 0.25;
  const Vec3 error1(0.1, -0.2, 0.3);
  const Vec3 error2(0.0, 0.0, -0.4);
  std::vector<std::optional<estimators::Estimate>> estimates{
      std::nullopt, spatial_estimate(Vec3(10, 0, 2) + error1, covariance),
      spatial_estimate(Vec3(0, 10, 3) + error2, covariance)};
  const ErrorStats stats = score(truth, is_anchor, estimates, &truth_z);
  EXPECT_EQ(stats.scored, 2);
  EXPECT_NEAR(stats.rmse_m, std::sqrt((error1.squaredNorm() + error2.squaredNorm()) / 2.0), 1e-12);
  EXPECT_NEAR(stats.max_error_m, std::max(error1.norm(), error2.norm()), 1e-12);
  const Mat3 information = covariance.inverse();
  EXPECT_NEAR(stats.nees, 0.5 * (error1.dot(information * error1) + error2.dot(information * error2)), 1e-9);
  // A planar estimate of a point in space is not an estimate of it.
  estimates[2]->altitude.reset();
  const ErrorStats without_z = score(truth, is_anchor, estimates, &truth_z);
  EXPECT_EQ(without_z.scored, 1);
  EXPECT_EQ(without_z.missing, 1);
}

}  // namespace
}  // namespace swarmloc::world
