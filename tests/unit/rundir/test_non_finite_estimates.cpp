// Whom the final figures cover (docs/robustness.md, "Non-finite estimates"). A NaN or Inf estimate is a
// broken agent, not a missing one: it is counted, it makes the step's figures +inf, and the run's table and
// summary say the results are not valid, so a diverged agent cannot leave a smaller, clean-looking RMSE
// behind. The NEES says over how many agents it is taken. A simulated run's record and Monte Carlo's
// trials.csv: tests/unit/sim/test_simulated_run_directory.cpp.
#include <gtest/gtest.h>

#include <string>

#include "run_report_fixtures.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/rundir/run_record.hpp"
#include "swarmloc/world/metrics.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::rundir {
namespace {

using testing::eight_agent_scenario;
using testing::estimates_near_truth;
using testing::first_non_anchor;
using testing::kInfinity;
using testing::kNotANumber;

TEST(NonFiniteEstimates, ABrokenMeanIsCountedAndMakesTheErrorInfinite) {
  const world::World world = world::build_world(eight_agent_scenario());
  auto estimates = estimates_near_truth(world);
  const world::ErrorStats clean = world::score(world, estimates);
  EXPECT_NEAR(clean.rmse_m, 0.1, 1e-12);
  EXPECT_EQ(clean.non_finite, 0);

  estimates[first_non_anchor(world)]->mean_m.x() = kNotANumber;
  const world::ErrorStats broken = world::score(world, estimates);
  EXPECT_EQ(broken.non_finite, 1);
  EXPECT_EQ(broken.missing, 0) << "a broken estimate is not a missing one";
  EXPECT_EQ(broken.scored, clean.scored - 1);
  EXPECT_EQ(broken.rmse_m, kInfinity) << "not the 0.1 m of the others";
  EXPECT_EQ(broken.max_error_m, kInfinity);
  EXPECT_NEAR(broken.nees, 0.01, 1e-12) << "the NEES of the finite ones; their covariances are fine";

  estimates[first_non_anchor(world)].reset();
  EXPECT_EQ(world::score(world, estimates).missing, 1) << "no report is still just missing";
}

// Recorded data (MRCLAM) has instants without ground truth: nothing to score is not a broken estimate.
TEST(NonFiniteEstimates, AnAgentWithoutGroundTruthIsMissingNotBroken) {
  world::World world = world::build_world(eight_agent_scenario());
  const auto estimates = estimates_near_truth(world);
  world.truth[first_non_anchor(world)].x() = kNotANumber;
  const world::ErrorStats stats = world::score(world, estimates);
  EXPECT_EQ(stats.non_finite, 0);
  EXPECT_EQ(stats.missing, 1);
  EXPECT_NEAR(stats.rmse_m, 0.1, 1e-12);
}

TEST(NonFiniteEstimates, TheNeesSaysHowManyAgentsItCovers) {
  const world::World world = world::build_world(eight_agent_scenario());
  auto estimates = estimates_near_truth(world);
  estimates[first_non_anchor(world)]->valid = false;  // no covariance to judge (e.g. not yet localized)
  const world::ErrorStats stats = world::score(world, estimates);
  EXPECT_EQ(stats.nees_agents, stats.scored - 1);
  RunRecord record;
  record.agents = world.size();
  StepMetrics metrics;
  metrics.errors = stats;
  record.metrics.push_back(metrics);
  const std::string table = result_table(record);
  const std::string covered = std::to_string(stats.scored - 1) + " of " + std::to_string(stats.scored);
  EXPECT_NE(table.find("NEES over agents with covariance"), std::string::npos) << table;
  EXPECT_NE(table.find(covered), std::string::npos) << table;
  EXPECT_EQ(summary_json(record)["final"]["nees_agents"], stats.scored - 1);
}

TEST(NonFiniteEstimates, ABrokenCovarianceMakesTheNeesInfiniteButNotTheError) {
  const world::World world = world::build_world(eight_agent_scenario());
  auto estimates = estimates_near_truth(world);
  estimates[first_non_anchor(world)]->covariance(0, 1) = kInfinity;
  const world::ErrorStats stats = world::score(world, estimates);
  EXPECT_EQ(stats.non_finite, 1);
  EXPECT_NEAR(stats.rmse_m, 0.1, 1e-12);
  EXPECT_EQ(stats.nees, kInfinity);
  // Without a claim to a covariance (not yet localized), whatever it holds is not judged.
  estimates[first_non_anchor(world)]->valid = false;
  EXPECT_EQ(world::score(world, estimates).non_finite, 0);
}

TEST(NonFiniteEstimates, ABrokenFieldIsCountedOncePerAgent) {
  const auto scenario =
      config::load_scenario(std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/joint_field.yaml",
                            {"world.agents=4", "world.anchors=1", "world.comm_radius_m=100"});
  const world::World world = world::build_world(scenario);
  auto estimates = estimates_near_truth(world);
  for (auto& estimate : estimates) estimate->field = world.field;
  EXPECT_NEAR(world::score(world, estimates).field_rmse, 0.0, 1e-12);
  const std::size_t agent = first_non_anchor(world);
  estimates[agent]->field(0) = kNotANumber;
  EXPECT_EQ(world::score(world, estimates).non_finite, 1);
  EXPECT_EQ(world::score(world, estimates).field_rmse, kInfinity);
  estimates[agent]->mean_m.x() = kNotANumber;  // position and field broken: one broken agent
  EXPECT_EQ(world::score(world, estimates).non_finite, 1);
}

}  // namespace
}  // namespace swarmloc::rundir
