// Agents started elsewhere take their manifest over DDS (dds/manifest_topic.hpp): `swarmloc run
// --no-launch` plus agent processes started by the test with nothing but --id and --domain (no
// scenario file, no manifest file, no world) must reproduce, bit for bit, the run that `swarmloc run`
// launches itself (lockstep: DDS equals the simulator, so the two runs compute the same estimates).
#include <gtest/gtest.h>

#include <string>

#include "process_helpers.hpp"

namespace manifest_dds_test {
namespace {

using swarmloc::testing::fresh_directory;
using swarmloc::testing::read_json;
using swarmloc::testing::read_text;
using swarmloc::testing::run_command;

const std::string kBinary = SWARMLOC_BINARY;
const std::string kAgentBinary = SWARMLOC_AGENT_BINARY;
const std::string kScenario = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/ieif.yaml";
constexpr int kAgents = 6;
const std::string kWorld =
    " --set world.agents=6 --set world.anchors=3 --set run.steps=40 --set run.mode=lockstep"
    " --set run.startup_timeout_s=60";

TEST(ManifestOverDds, AgentsStartedWithOnlyIdAndDomainReproduceALaunchedLockstepRun) {
  const auto launched = fresh_directory("manifest-launched");
  const auto reference = run_command(kBinary + " run " + kScenario + " -q --out " + launched.string() +
                                     kWorld + " --set dds.domain_id=222");
  ASSERT_TRUE(swarmloc::testing::completed_run(reference.exit_code)) << reference.output;

  // Half the agents start before the orchestrator, half after; both agent executables.
  const auto dir = fresh_directory("manifest-no-launch");
  const auto logs = dir.string() + ".agents";
  auto agent = [&](int id) {
    const std::string binary = id % 2 == 0 ? kAgentBinary : kBinary + " agent";
    const std::string out = logs + "/agent_" + std::to_string(id);
    return "(timeout -k 5 100 " + binary + " --id " + std::to_string(id) + " --domain 221 > " + out +
           ".log 2>&1; echo $? > " + out + ".rc) & ";
  };
  std::string script = "mkdir -p " + logs + "; ";
  for (int id = 0; id < kAgents / 2; ++id) script += agent(id);
  script += "timeout -k 5 110 " + kBinary + " run " + kScenario + " --no-launch -q --out " + dir.string() +
            kWorld + " --set dds.domain_id=221 > " + logs + "/orchestrator.log 2>&1 & orch=$!; sleep 1; ";
  for (int id = kAgents / 2; id < kAgents; ++id) script += agent(id);
  script += "wait $orch; rc=$?; wait; exit $rc";
  const auto run = run_command("bash -c '" + script + "'");
  ASSERT_TRUE(swarmloc::testing::completed_run(run.exit_code)) << read_text(logs + "/orchestrator.log");

  for (int id = 0; id < kAgents; ++id) {
    const std::string out = logs + "/agent_" + std::to_string(id);
    EXPECT_EQ(read_text(out + ".rc"), "0\n") << read_text(out + ".log");
    EXPECT_NE(read_text(out + ".log").find("manifest of run"), std::string::npos) << read_text(out + ".log");
  }
  const auto summary = read_json(dir / "summary.json");
  EXPECT_EQ(summary["final"]["missing_agents"], 0);
  EXPECT_EQ(summary["final"]["scored_agents"], kAgents - 3);
  EXPECT_EQ(read_text(dir / "estimates.csv"), read_text(launched / "estimates.csv"));
  EXPECT_GT(read_text(dir / "estimates.csv").size(), 1000U);
}

TEST(ManifestOverDds, AnAgentWithNoRunToJoinExitsOneNamingTheDomain) {
  const auto result =
      run_command("timeout -k 5 30 " + kAgentBinary + " --id 2 --domain 220 --manifest-timeout 1 2>&1");
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("no manifest for agent 2 on DDS domain 220"), std::string::npos)
      << result.output;
}

}  // namespace
}  // namespace manifest_dds_test
