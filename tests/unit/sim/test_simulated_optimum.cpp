// What a simulated run reports of its optimum (docs/algorithms.md §1.3.2): summary.json's `optimum` block
// and `efficiency`, the result table's efficiency line, metrics.csv's checkpoints and trials.csv's columns,
// for static and moving worlds, and dml at its fixed point. The solver itself:
// tests/unit/world/test_optimum.cpp.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/rundir/run_record.hpp"
#include "swarmloc/sim/simulator.hpp"
#include "swarmloc/world/optimum.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::sim {
namespace {

const std::string kOptimumScenarios = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/";

TEST(OptimumReport, SummaryTableMetricsAndTrialsCarryTheOptimumAndTheEfficiency) {
  const auto s =
      config::load_scenario(kOptimumScenarios + "default.yaml", {"algorithm.name=dml", "run.steps=40"});
  const rundir::RunRecord record = run_simulation(s);
  const auto summary = rundir::summary_json(record);
  const auto& optimum = summary["optimum"];
  EXPECT_EQ(optimum["kind"], "batch_ml");
  EXPECT_EQ(optimum["data"], "all_draws");
  EXPECT_EQ(optimum["anchors"], "fixes") << "as the bound reports dml's row (anchor_fix_std_m = 0: known)";
  EXPECT_EQ(optimum["step"], 39);
  EXPECT_TRUE(optimum["converged"].get<bool>());
  const double optimum_rmse = optimum["rmse_m"].get<double>();
  EXPECT_NEAR(summary["efficiency"].get<double>(), record.final_metrics()->errors.rmse_m / optimum_rmse,
              1e-12);
  // The optimum of the draws is near the bound of the draws (one world, one trial: within a factor 2).
  EXPECT_GT(optimum_rmse, 0.5 * summary["bound"]["rmse_m"].get<double>());
  EXPECT_LT(optimum_rmse, 2.0 * summary["bound"]["rmse_m"].get<double>());
  EXPECT_NE(rundir::result_table(record).find("final RMSE / optimum (efficiency)"), std::string::npos);
  int solved_rows = 0;
  for (const auto& m : record.metrics) solved_rows += std::isfinite(m.optimum_rmse_m) ? 1 : 0;
  EXPECT_EQ(solved_rows, 20) << "every second step of 40 (25 checkpoints at most)";

  MonteCarloResult result = run_monte_carlo(s, 3, 1);
  ASSERT_EQ(result.final_optimum_per_trial.size(), 3U);
  EXPECT_NE(result.final_optimum_per_trial[0], result.final_optimum_per_trial[1]) << "each trial's own draws";
  const auto directory =
      std::filesystem::temp_directory_path() / ("swarmloc-optimum-" + std::to_string(::getpid()));
  std::filesystem::create_directories(directory);
  write_monte_carlo(directory, result);
  std::ifstream in(directory / "trials.csv");
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header,
            "trial,final_rmse_m,flagged_agents,non_finite_steps,bound_rmse_m,bound_ratio,optimum_rmse_m,"
            "efficiency");
  std::string row;
  std::getline(in, row);
  std::stringstream fields(row);
  std::vector<double> values;
  for (std::string field; std::getline(fields, field, ',');) values.push_back(std::stod(field));
  ASSERT_EQ(values.size(), 8U);
  EXPECT_NEAR(values[6], result.final_optimum_per_trial[0], 1e-9 * values[6]);
  EXPECT_NEAR(values[7], values[1] / values[6], 1e-6);
  std::filesystem::remove_all(directory);
}

TEST(OptimumReport, MovingWorldsReportTheSmootherAndOtherModelsSayWhyNone) {
  const auto ea2 = config::load_scenario(kOptimumScenarios + "ea2.yaml", {"run.steps=20"});
  const rundir::RunRecord record = run_simulation(ea2);
  EXPECT_EQ(record.optimum.kind, world::OptimumKind::kMapSmoother);
  EXPECT_TRUE(std::isfinite(record.final_metrics()->optimum_rmse_m));
  EXPECT_EQ(rundir::summary_json(record)["optimum"]["data"], "one_per_edge");
  EXPECT_EQ(rundir::summary_json(record)["optimum"]["anchors"], "fixes");
  for (const std::string name : {"jacobi.yaml", "dle.yaml", "multipath_bp.yaml"}) {
    const auto s = config::load_scenario(kOptimumScenarios + name, {"run.steps=3"});
    const world::OptimumAccumulator accumulator(world::build_world(s), s);
    EXPECT_EQ(accumulator.result().kind, world::OptimumKind::kNone) << name;
    EXPECT_FALSE(accumulator.result().reason.empty()) << name;
  }
}

TEST(OptimumReport, DmlAtItsFixedPointIsTheOptimumOfItsDraws) {
  // 2000 quiet sweeps after the last step: every agent at the fixed point of dml's pooled draws, the ML of
  // every draw (docs/algorithms.md §9, docs/validation.md "How far one trial strays").
  const auto s = config::load_scenario(kOptimumScenarios + "default.yaml",
                                       {"algorithm.name=dml", "run.steps=60", "run.settle_s=200"});
  const rundir::RunRecord record = run_simulation(s);
  EXPECT_NEAR(rundir::run_efficiency(record), 1.0, 0.01);
}

TEST(OptimumReport, AMirrorTheDataCannotRuleOutIsComparedWithTheMlOnTheEstimatesSide) {
  // Seed 47: agent 21 has two neighbours, and its mirror image fits its ranges as well as its true position;
  // dml starts it on the mirror side and flags it (docs/validation.md, "The default world over 50 seeds").
  // Both are the ML of the draws: the optimum is solved from the run's estimates too (docs/algorithms.md
  // §1.3.2), so the efficiency is 1, not the ~200 of the truth's side.
  const auto s = config::load_scenario(kOptimumScenarios + "default.yaml", {"algorithm.name=dml", "seed=47"});
  const rundir::RunRecord record = run_simulation(s);
  EXPECT_GT(record.final_metrics()->errors.flagged, 0);
  EXPECT_GT(record.final_metrics()->errors.rmse_m, 0.5);
  EXPECT_NEAR(rundir::run_efficiency(record), 1.0, 0.05);
  EXPECT_EQ(rundir::summary_json(record)["optimum"]["start"], "estimates");
  EXPECT_NE(rundir::result_table(record).find("(in the estimates' basin)"), std::string::npos);
}

}  // namespace
}  // namespace swarmloc::sim
