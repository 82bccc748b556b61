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

TEST(FusionCenter, FusionRoleRejectsADistributedAlgorithm) {
  const auto result = run_command(kBinary + " agent --role fusion --scenario " + kScenario +
                                  " --set algorithm.name=ieif --set dds.domain_id=15");
  EXPECT_EQ(result.exit_code, 2) << result.output;
  EXPECT_NE(result.output.find("algorithm.name"), std::string::npos) << result.output;
}

}  // namespace
