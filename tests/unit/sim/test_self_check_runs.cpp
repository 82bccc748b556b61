// The self-check end to end (docs/algorithms.md §1.6): a world where the filters fall into a folded
// solution gets flagged agents in its results, the default world gets none.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/sim/simulator.hpp"

namespace swarmloc::sim {
namespace {

/// scenarios/ieif.yaml with `algorithm` and `seed`, run as Monte Carlo trial `trial`.
rundir::RunRecord default_world_run(const std::string& algorithm, int seed, std::uint64_t trial) {
  const auto scenario =
      config::load_scenario(std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/ieif.yaml",
                            {"seed=" + std::to_string(seed), "algorithm.name=" + algorithm});
  SimOptions options;
  options.trial = trial;
  return run_simulation(scenario, options);
}

// Seed 3 holds two agents of degree 3 that the filters can fold across their neighbours
// (docs/algorithms.md §1.6). Verified cases: ieif trial 1 ends 3.8 m off with 2 agents flagged, ekf trial 1
// 0.53 m off with 4; seed 1 trial 0 ends near the bound (ieif 0.032 m, ekf 0.030 m) with none.
TEST(SelfCheckRuns, AFoldedSolutionIsFlaggedAndTheDefaultWorldIsNot) {
  for (const std::string algorithm : {"ieif", "ekf"}) {
    SCOPED_TRACE(algorithm);
    const rundir::RunRecord folded = default_world_run(algorithm, 3, 1);
    ASSERT_GT(folded.final_metrics()->errors.rmse_m, 0.3);
    EXPECT_GT(folded.final_metrics()->errors.flagged, 0);
    EXPECT_GT(rundir::summary_json(folded)["final"]["flagged_agents"].get<int>(), 0);

    const rundir::RunRecord healthy = default_world_run(algorithm, 1, 0);
    ASSERT_LT(healthy.final_metrics()->errors.rmse_m, 0.05);
    EXPECT_EQ(healthy.final_metrics()->errors.flagged, 0);
    EXPECT_EQ(rundir::summary_json(healthy)["final"]["flagged_agents"].get<int>(), 0);
  }
}

// Seed 3 trial 2: the EKF ends 4.0 m off in an exact flip of agents 5 and 13 whose ranges all fit, so only
// the fusion centre's graph test sees it (docs/algorithms.md §1.6, "Graph"): verified 7 agents flagged.
// On ea2's moving world pairs come within range unranged, so the test is off: verified 0 flagged.
TEST(SelfCheckRuns, TheFusionCentreFlagsAFlipOnlyTheGraphRevealsAndStaysQuietOnAMovingWorld) {
  const rundir::RunRecord flipped = default_world_run("ekf", 3, 2);
  ASSERT_GT(flipped.final_metrics()->errors.rmse_m, 3.0);
  EXPECT_GT(flipped.final_metrics()->errors.flagged, 0);

  const auto moving = config::load_scenario(std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/ea2.yaml", {});
  const rundir::RunRecord tracked = run_simulation(moving, SimOptions{});
  EXPECT_EQ(tracked.final_metrics()->errors.flagged, 0);
}

std::vector<std::string> lines_of(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

TEST(SelfCheckRuns, TheVerdictIsInEstimatesAndAgentsCsv) {
  const rundir::RunRecord folded = default_world_run("ieif", 3, 1);
  const auto directory = std::filesystem::path(::testing::TempDir()) / "self_check_run";
  std::filesystem::remove_all(directory);
  rundir::write_run_directory(directory, folded);
  const auto estimates = lines_of(directory / "estimates.csv");
  ASSERT_FALSE(estimates.empty());
  EXPECT_TRUE(estimates.front().ends_with(",error_m,inconsistent")) << estimates.front();
  const auto agents = lines_of(directory / "agents.csv");
  ASSERT_FALSE(agents.empty());
  EXPECT_TRUE(agents.front().ends_with(",flagged_final")) << agents.front();
  int flagged_rows = 0;
  for (std::size_t r = 1; r < agents.size(); ++r) flagged_rows += agents[r].ends_with(",1") ? 1 : 0;
  EXPECT_EQ(flagged_rows, folded.final_metrics()->errors.flagged);
  // The final step's rows of estimates.csv flag the same number of agents.
  const std::string final_step = std::to_string(folded.final_metrics()->step) + ",";
  int flagged_final_rows = 0;
  for (const auto& line : estimates)
    flagged_final_rows += line.starts_with(final_step) && line.ends_with(",1");
  EXPECT_EQ(flagged_final_rows, folded.final_metrics()->errors.flagged);
  std::filesystem::remove_all(directory);
}

}  // namespace
}  // namespace swarmloc::sim
