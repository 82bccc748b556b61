// The bound a simulated run reports (docs/algorithms.md §1.3.1): ea2's posterior bound of its moving truth in
// summary.json, and Monte Carlo's bound over trials with their own trajectories. The bounds themselves:
// tests/unit/world/test_bound.cpp.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <string>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/rundir/run_record.hpp"
#include "swarmloc/sim/simulator.hpp"

namespace swarmloc::sim {
namespace {

const std::string kSimulatedBoundScenarios = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/";

TEST(RunBoundReport, Ea2ReportsThePosteriorBoundOfItsMovingTruth) {
  const auto s = config::load_scenario(kSimulatedBoundScenarios + "ea2.yaml", {});
  const rundir::RunRecord record = run_simulation(s);
  const auto summary = rundir::summary_json(record);
  const auto& bound = summary["bound"];
  EXPECT_EQ(bound["kind"], "pcrb");
  EXPECT_EQ(bound["data"], "one_per_edge");
  EXPECT_EQ(bound["anchors"], "fixes");
  // The static all-draws CRLB of the old report is 0.27 m; the PCRB with all ranges is ~0.64–0.69 m.
  EXPECT_NEAR(bound["all_data_rmse_m"].get<double>(), 0.66, 0.08);
  EXPECT_GT(bound["rmse_m"].get<double>(), bound["all_data_rmse_m"].get<double>());
  EXPECT_NEAR(bound["ratio"].get<double>(),
              record.final_metrics()->errors.rmse_m / bound["rmse_m"].get<double>(), 1e-12);
  EXPECT_NEAR(summary["crlb"]["accumulated_rmse_m"].get<double>(), 0.266, 0.001) << "kept for older readers";
}

TEST(RunBoundReport, MonteCarloComparesWithTheRootMeanSquareOfEachTrialsBound) {
  // Each ea2 trial has its own trajectory, so its own PCRB: the Monte Carlo bound is √(mean of bound²).
  const auto s = config::load_scenario(kSimulatedBoundScenarios + "ea2.yaml", {"run.steps=15"});
  constexpr int kTrials = 3;
  std::array<double, kTrials> final_bound{};
  const auto result = run_monte_carlo(s, kTrials, 1, {}, [&](int trial, const rundir::RunRecord& record) {
    final_bound[static_cast<std::size_t>(trial)] = record.final_metrics()->bound_rmse_m;
  });
  double mean_square = 0.0;
  for (double b : final_bound) mean_square += b * b / kTrials;
  EXPECT_NE(final_bound[0], final_bound[1]);
  EXPECT_NEAR(result.steps.back().bound_rmse_m, std::sqrt(mean_square), 1e-12);
}

}  // namespace
}  // namespace swarmloc::sim
