// Whom the final figures cover (docs/robustness.md, "Non-finite estimates"). A NaN or Inf estimate is a
// broken agent, not a missing one: it is counted, it makes the step's figures +inf, and the run's table and
// summary say the results are not valid, so a diverged agent cannot leave a smaller, clean-looking RMSE
// behind. The NEES says over how many agents it is taken.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/rundir/run_record.hpp"
#include "swarmloc/sim/simulator.hpp"
#include "swarmloc/world/metrics.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::rundir {
namespace {

constexpr double kNotANumber = std::numeric_limits<double>::quiet_NaN();
constexpr double kInfinity = std::numeric_limits<double>::infinity();

config::Scenario eight_agent_scenario() {
  return config::load_scenario(std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/ieif.yaml",
                               {"run.steps=4", "world.agents=8", "world.anchors=3", "world.area_m=15"});
}

/// Every agent at its truth plus 0.1 m east, with a unit covariance.
std::vector<std::optional<estimators::Estimate>> estimates_near_truth(const world::World& world) {
  std::vector<std::optional<estimators::Estimate>> estimates(world.truth.size());
  for (std::size_t i = 0; i < world.truth.size(); ++i) {
    estimators::Estimate estimate;
    estimate.mean_m = world.truth[i] + Vec2(0.1, 0.0);
    estimate.covariance = Mat2::Identity();
    estimate.valid = true;
    estimates[i] = estimate;
  }
  return estimates;
}

std::size_t first_non_anchor(const world::World& world) {
  std::size_t i = 0;
  while (world.is_anchor[i]) ++i;
  return i;
}

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

TEST(NonFiniteEstimates, TheRunRecordSaysTheResultsAreNotValid) {
  const auto scenario = eight_agent_scenario();
  RunRecord record = sim::run_simulation(scenario, sim::SimOptions{});
  ASSERT_EQ(record.metrics.size(), 4U);
  EXPECT_EQ(non_finite_estimates(record).steps, 0U);
  EXPECT_EQ(result_table(record).find("NOT VALID"), std::string::npos);
  EXPECT_NE(result_table(record).find("agents scored at the final step"), std::string::npos);
  const double clean_whole = whole_run_error(record).rmse_m;
  ASSERT_TRUE(std::isfinite(clean_whole));

  const world::World world = world::build_world(scenario);
  auto estimates = estimates_near_truth(world);
  estimates[first_non_anchor(world)]->mean_m.y() = kInfinity;
  record.metrics[1].errors = world::score(world, estimates);  // one agent diverged at step 1, then recovered
  const auto broken = non_finite_estimates(record);
  EXPECT_EQ(broken.steps, 1U);
  EXPECT_EQ(broken.first_step, record.metrics[1].step);
  EXPECT_EQ(broken.most_agents, 1);
  EXPECT_EQ(whole_run_error(record).rmse_m, kInfinity) << "the whole run must not skip the broken step";
  EXPECT_NE(result_table(record).find("NOT VALID"), std::string::npos) << result_table(record);
  const auto summary = summary_json(record);
  EXPECT_EQ(summary["non_finite_estimates"]["steps"], 1);
  EXPECT_TRUE(summary["whole_run"]["rmse_m"].is_null());
  EXPECT_EQ(summary["final"]["non_finite_agents"], 0) << "the final step itself is clean";
}

TEST(NonFiniteEstimates, TrialsCsvNamesTheTrialsThatBroke) {
  sim::MonteCarloResult result;
  result.trials = 2;
  result.final_rmse_per_trial = {0.1, kInfinity};
  result.final_flagged_per_trial = {0, 0};
  result.non_finite_steps_per_trial = {0, 3};
  const auto directory =
      std::filesystem::temp_directory_path() / ("swarmloc-non-finite-trials-" + std::to_string(::getpid()));
  std::filesystem::remove_all(directory);
  std::filesystem::create_directories(directory);
  sim::write_monte_carlo(directory, result);
  std::ifstream in(directory / "trials.csv");
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(),
            "trial,final_rmse_m,flagged_agents,non_finite_steps,bound_rmse_m,bound_ratio,optimum_rmse_m,"
            "efficiency\n0,0.1,0,0,nan,nan,nan,nan\n1,inf,0,3,nan,nan,nan,nan\n");
  std::filesystem::remove_all(directory);
}

}  // namespace
}  // namespace swarmloc::rundir
