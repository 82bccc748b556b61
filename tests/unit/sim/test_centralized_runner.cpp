// The in-process fusion centre (centralized_runner.hpp): measurement assembly, the runner and E-A2's
// LB-EKF + VR vs EKF comparison (docs/algorithms.md §2.8).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "swarmloc/run/fusion_centre.hpp"
#include "swarmloc/run/manifests.hpp"
#include "swarmloc/runtime/agent_factory.hpp"
#include "swarmloc/sim/centralized_runner.hpp"
#include "swarmloc/sim/simulator.hpp"

namespace swarmloc::sim {
namespace {

const std::string kEa2 = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/ea2.yaml";

config::Scenario ea2(const std::vector<std::string>& overrides = {}) {
  return config::load_scenario(kEa2, overrides);
}

TEST(CentralizedRunner, KnowsTheCentralizedAlgorithms) {
  for (const char* name : {"ekf", "lbekf", "lbekf_vr", "lbekf_i"})
    EXPECT_TRUE(config::runs_in_fusion_centre(name)) << name;
  for (const char* name : {"ieif", "iekf", "dle", "bp", ""})
    EXPECT_FALSE(config::runs_in_fusion_centre(name)) << name;
}

TEST(CentralizedRunner, OneRangePerEdgeFromTheLowerEndpointUnlessItsBatchIsMissing) {
  config::Scenario scenario;
  scenario.noise.range_std_m = 2.0;
  scenario.noise.anchor_fix_std_m = 0.0;  // exact anchors: floored variance, still finite
  estimators::MeasurementBatch b0, b1, b2;
  b0.ranges = {{1, 10.0, 2.0}, {2, 20.0, 2.0}};
  b1.ranges = {{0, 11.0, 2.0}, {2, 30.0, 2.0}};
  b2.ranges = {{0, 21.0, 2.0}, {1, 31.0, 2.0}};
  b0.fix = estimators::AbsoluteFix{Vec2(1.0, 2.0), Mat2::Zero(), std::nullopt};

  auto all = run::centralized_measurements(scenario, {&b0, &b1, &b2});
  ASSERT_EQ(all.ranges.size(), 3U);
  EXPECT_DOUBLE_EQ(all.ranges[0].range_m, 10.0);  // (0,1) by agent 0
  EXPECT_DOUBLE_EQ(all.ranges[1].range_m, 20.0);  // (0,2) by agent 0
  EXPECT_DOUBLE_EQ(all.ranges[2].range_m, 30.0);  // (1,2) by agent 1
  EXPECT_DOUBLE_EQ(all.range_var, 4.0);
  ASSERT_EQ(all.beacon_fixes.size(), 1U);
  EXPECT_EQ(all.beacon_fixes[0].first, 0);
  EXPECT_GT(all.beacon_var, 0.0);

  auto without_0 = run::centralized_measurements(scenario, {nullptr, &b1, &b2});
  ASSERT_EQ(without_0.ranges.size(), 3U);  // agent 0's edges come from its neighbours instead
  for (const auto& range : without_0.ranges) EXPECT_LT(range.i, range.j);
  EXPECT_DOUBLE_EQ(without_0.ranges[0].range_m, 11.0);
  EXPECT_DOUBLE_EQ(without_0.ranges[1].range_m, 30.0);
  EXPECT_DOUBLE_EQ(without_0.ranges[2].range_m, 21.0);
  EXPECT_TRUE(without_0.beacon_fixes.empty());
}

TEST(CentralizedRunner, RunSimulationDelegatesAndReportsTheTotalMse) {
  const auto scenario = ea2({"run.steps=20"});
  const auto record = run_simulation(scenario);
  EXPECT_EQ(record.mode, "sim");
  ASSERT_EQ(record.metrics.size(), 20U);
  EXPECT_EQ(record.estimates.size(), 20U * 30U);
  ASSERT_TRUE(record.extra.contains("final_total_mse_m2"));
  const double total = record.extra["final_total_mse_m2"];
  EXPECT_GT(total, 0.0);
  // Total over all 30 agents >= the non-anchors' share, which is rmse² · scored.
  const auto& last = record.final_metrics()->errors;
  EXPECT_EQ(last.scored, 22);
  EXPECT_GE(total, last.rmse_m * last.rmse_m * last.scored - 1e-9);
  for (const auto& summary : record.agent_summaries) EXPECT_EQ(summary.steps_run, 20U);
}

TEST(CentralizedRunner, AgentsOfACentralizedRunAreSensorsOnly) {
  const auto scenario = ea2();
  const auto world = world::build_world(scenario);
  auto estimator = runtime::make_agent_estimator(
      scenario, run::agent_manifest(run::shared_manifest(scenario, world), world, 3));
  EXPECT_FALSE(estimator->initial_outbox().state.has_value());
  EXPECT_FALSE(estimator->estimate().valid);
  EXPECT_TRUE(estimator->estimate().mean_m.isApprox(world.setup_of(3).initial_guess_m));
}

TEST(CentralizedRunner, FiltersImproveOnTheInitialGuess) {
  for (const char* algorithm : {"ekf", "lbekf", "lbekf_vr", "lbekf_i"}) {
    const auto record = run_simulation(ea2({std::string("algorithm.name=") + algorithm}));
    const double total = record.extra["final_total_mse_m2"];
    // Initial error: 30 agents × 2 coordinates × 5 m² = 300 m² in expectation (22 non-anchors: 220 m²).
    EXPECT_LT(total, 150.0) << algorithm;
  }
}

// E-A2 (Khan et al. Fig. 6): LB-EKF + VR's total MSE close to the dense EKF's. Averaged over a few seeds
// (configurations) so one unlucky draw does not decide the comparison.
TEST(CentralizedRunner, LbEkfWithRelabelingIsWithinFifteenPercentOfTheEkf) {
  double ekf_sum = 0.0;
  double vr_sum = 0.0;
  for (const int seed : {1, 2, 3, 4}) {
    const std::string seed_flag = "seed=" + std::to_string(seed);
    const auto ekf = run_simulation(ea2({seed_flag, "algorithm.name=ekf"}));
    const auto vr = run_simulation(ea2({seed_flag, "algorithm.name=lbekf_vr"}));
    const double ekf_total = ekf.extra["final_total_mse_m2"];
    const double vr_total = vr.extra["final_total_mse_m2"];
    std::printf("seed %d: EKF %.3f m², LB-EKF+VR %.3f m² (graph bandwidth after VR %d)\n", seed, ekf_total,
                vr_total, vr.extra["fusion_center"]["graph_bandwidth"].get<int>());
    ekf_sum += ekf_total;
    vr_sum += vr_total;
  }
  EXPECT_LT(vr_sum, 1.15 * ekf_sum) << "LB-EKF+VR " << vr_sum << " vs EKF " << ekf_sum
                                    << " (sums over seeds)";
  EXPECT_GT(vr_sum, 0.85 * ekf_sum) << "LB-EKF+VR " << vr_sum << " vs EKF " << ekf_sum
                                    << " (sums over seeds)";
}

}  // namespace
}  // namespace swarmloc::sim
