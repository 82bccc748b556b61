// Issue 3 acceptance: LB-EKF + VR in a fusion-centre process over DDS (30 agent processes as sensors,
// the fusion centre, the orchestrator) on the E-A2 scenario matches the simulator's final total MSE.
#include <gtest/gtest.h>

#include "process_helpers.hpp"

namespace {

using swarmloc::testing::count_processes_matching;
using swarmloc::testing::fresh_directory;
using swarmloc::testing::read_json;
using swarmloc::testing::run_command;

const std::string kBinary = SWARMLOC_BINARY;
const std::string kScenario = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/ea2.yaml";

// 100 steps at 10 Hz: 10 s of world time. The fusion centre steps each world step once every agent's
// batch of that step has arrived, so it uses the same measurements as the simulator.
const std::string kFlags = " -q --set run.rate_hz=10 --set run.steps=100";

TEST(FusionCenter, LbEkfVrOverDdsMatchesTheSimulatorsFinalTotalMse) {
  const auto sim_dir = fresh_directory("fusion-sim");
  const auto sim = run_command(kBinary + " sim " + kScenario + " --out " + sim_dir.string() + kFlags);
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  const auto dds_dir = fresh_directory("fusion-dds");
  const auto dds = run_command(kBinary + " run " + kScenario + " --out " + dds_dir.string() + kFlags +
                               " --set dds.domain_id=15");
  ASSERT_TRUE(swarmloc::testing::completed_run(dds.exit_code)) << dds.output;
  EXPECT_EQ(count_processes_matching(dds_dir.string()), 0)
      << "agent or fusion-centre processes outlived the run";

  const auto sim_summary = read_json(sim_dir / "summary.json");
  const auto dds_summary = read_json(dds_dir / "summary.json");
  EXPECT_EQ(dds_summary["agents"], 30);
  EXPECT_EQ(dds_summary["processes"], 32);  // 30 agents + the fusion centre + the orchestrator
  EXPECT_EQ(dds_summary["final"]["scored_agents"], 22);
  EXPECT_EQ(dds_summary["fusion_center"]["estimated_agents"], 30);
  const double sim_total = sim_summary["final_total_mse_m2"];
  const double dds_total = dds_summary["final_total_mse_m2"];
  std::printf("final total MSE: DDS %.4f m², simulator %.4f m²\n", dds_total, sim_total);
  ASSERT_GT(sim_total, 0.0);
  EXPECT_NEAR(dds_total, sim_total, 0.10 * sim_total) << "DDS " << dds_total << " vs simulator " << sim_total;
}

// The centralized EKF in a 3-D world (docs/design.md §3.1): the fusion-centre process reads the anchors' z
// from their fixes and publishes every agent's z, so the DDS run is scored in space as the simulator's is.
TEST(FusionCenter, EkfInA3dWorldOverDdsMatchesTheSimulator) {
  const std::string scenario = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/default3d.yaml";
  const std::string flags = " -q --set algorithm.name=ekf --set run.steps=60";
  const auto sim_dir = fresh_directory("fusion-3d-sim");
  const auto sim = run_command(kBinary + " sim " + scenario + " --out " + sim_dir.string() + flags);
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  const auto dds_dir = fresh_directory("fusion-3d-dds");
  const auto dds = run_command(kBinary + " run " + scenario + " --out " + dds_dir.string() + flags +
                               " --set dds.domain_id=16");
  ASSERT_TRUE(swarmloc::testing::completed_run(dds.exit_code)) << dds.output;
  const auto sim_summary = read_json(sim_dir / "summary.json");
  const auto dds_summary = read_json(dds_dir / "summary.json");
  EXPECT_EQ(dds_summary["dimensions"], 3);
  EXPECT_EQ(dds_summary["final"]["scored_agents"], 22);
  const double sim_rmse = sim_summary["final"]["rmse_m"];
  const double dds_rmse = dds_summary["final"]["rmse_m"];
  std::printf("3-D EKF final RMSE: DDS %.6f m, simulator %.6f m\n", dds_rmse, sim_rmse);
  EXPECT_LT(sim_rmse, 3.0 * sim_summary["bound"]["rmse_m"].get<double>());
  EXPECT_NEAR(dds_rmse, sim_rmse, 0.10 * sim_rmse);
  EXPECT_EQ(count_processes_matching(dds_dir.string()), 0);
}

TEST(FusionCenter, FusionRoleRejectsADistributedAlgorithm) {
  const auto result = run_command(kBinary + " agent --role fusion --scenario " + kScenario +
                                  " --set algorithm.name=ieif --set dds.domain_id=15");
  EXPECT_EQ(result.exit_code, 2) << result.output;
  EXPECT_NE(result.output.find("algorithm.name"), std::string::npos) << result.output;
}

}  // namespace
