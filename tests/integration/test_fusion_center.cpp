// Issue 3 acceptance: LB-EKF + VR in a fusion-centre process over DDS (30 agent processes as sensors,
// the fusion centre, the orchestrator) on the E-A2 scenario matches the simulator's final total MSE.
#include <gtest/gtest.h>

#include <optional>

#include "process_helpers.hpp"

namespace fusion_center_test {
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

/// The summaries of one scenario run by the simulator and over DDS (agent processes, the fusion centre, the
/// orchestrator) with the same flags; nullopt (after a test failure) if a run failed.
struct SimAndDds {
  nlohmann::json sim;
  nlohmann::json dds;
};
std::optional<SimAndDds> run_in_sim_and_over_dds(const std::string& scenario, const std::string& flags,
                                                 const std::string& name, int domain) {
  const auto sim_dir = fresh_directory(name + "-sim");
  const auto sim = run_command(kBinary + " sim " + scenario + " --out " + sim_dir.string() + flags);
  EXPECT_EQ(sim.exit_code, 0) << sim.output;
  const auto dds_dir = fresh_directory(name + "-dds");
  const auto dds = run_command(kBinary + " run " + scenario + " --out " + dds_dir.string() + flags +
                               " --set dds.domain_id=" + std::to_string(domain));
  EXPECT_TRUE(swarmloc::testing::completed_run(dds.exit_code)) << dds.output;
  EXPECT_EQ(count_processes_matching(dds_dir.string()), 0)
      << "agent or fusion-centre processes outlived the run";
  if (sim.exit_code != 0 || !swarmloc::testing::completed_run(dds.exit_code)) return std::nullopt;
  return SimAndDds{read_json(sim_dir / "summary.json"), read_json(dds_dir / "summary.json")};
}

TEST(FusionCenter, LbEkfVrOverDdsMatchesTheSimulatorsFinalTotalMse) {
  const auto runs = run_in_sim_and_over_dds(kScenario, kFlags, "fusion", 15);
  ASSERT_TRUE(runs);
  const auto& dds_summary = runs->dds;
  EXPECT_EQ(dds_summary["agents"], 30);
  EXPECT_EQ(dds_summary["processes"], 32);  // 30 agents + the fusion centre + the orchestrator
  EXPECT_EQ(dds_summary["final"]["scored_agents"], 22);
  EXPECT_EQ(dds_summary["fusion_center"]["estimated_agents"], 30);
  const double sim_total = runs->sim["final_total_mse_m2"];
  const double dds_total = dds_summary["final_total_mse_m2"];
  std::printf("final total MSE: DDS %.4f m², simulator %.4f m²\n", dds_total, sim_total);
  ASSERT_GT(sim_total, 0.0);
  EXPECT_NEAR(dds_total, sim_total, 0.10 * sim_total) << "DDS " << dds_total << " vs simulator " << sim_total;
}

// The centralized EKF in a 3-D world whose drones walk in space (docs/design.md §3.1): the fusion-centre
// process reads the anchors' z from their fixes and publishes every agent's z, the orchestrator moves z with
// x and y, so the DDS run is scored in space against the 3-D posterior CRB as the simulator's is.
TEST(FusionCenter, EkfInA3dWorldOverDdsMatchesTheSimulator) {
  const auto runs = run_in_sim_and_over_dds(std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/drones3d.yaml",
                                            " -q --set run.steps=40 --set run.rate_hz=20", "fusion-3d", 16);
  ASSERT_TRUE(runs);
  EXPECT_EQ(runs->dds["dimensions"], 3);
  EXPECT_EQ(runs->dds["bound"]["kind"], "pcrb");
  EXPECT_EQ(runs->dds["final"]["scored_agents"], 22);
  const double sim_rmse = runs->sim["final"]["rmse_m"];
  const double dds_rmse = runs->dds["final"]["rmse_m"];
  std::printf("3-D EKF final RMSE: DDS %.6f m, simulator %.6f m\n", dds_rmse, sim_rmse);
  EXPECT_LT(sim_rmse, 3.0 * runs->sim["bound"]["rmse_m"].get<double>());
  EXPECT_NEAR(dds_rmse, sim_rmse, 0.10 * sim_rmse);
}

TEST(FusionCenter, FusionRoleRejectsADistributedAlgorithm) {
  const auto result = run_command(kBinary + " agent --role fusion --scenario " + kScenario +
                                  " --set algorithm.name=ieif --set dds.domain_id=15");
  EXPECT_EQ(result.exit_code, 2) << result.output;
  EXPECT_NE(result.output.find("algorithm.name"), std::string::npos) << result.output;
}

}  // namespace
}  // namespace fusion_center_test
