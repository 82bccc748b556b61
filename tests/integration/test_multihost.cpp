// Multi-host run: deploy/netns/multihost.sh puts the orchestrator and 20 agent processes on four
// network namespaces ("hosts") joined by a bridge with 10 % UDP loss (nftables, in the switch's own
// namespace), Cyclone discovering by multicast on eth0. Needs root, `ip netns` and `nft`; skipped
// otherwise. The same scenario on loopback is the reference.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <string>

#include "process_helpers.hpp"

namespace {

using swarmloc::testing::count_processes_matching;
using swarmloc::testing::fresh_directory;
using swarmloc::testing::read_json;
using swarmloc::testing::run_command;

const std::string kBinary = SWARMLOC_BINARY;
const std::string kSourceDir = SWARMLOC_SOURCE_DIR;
const std::string kScript = kSourceDir + "/deploy/netns/multihost.sh";
const std::string kScenario = kSourceDir + "/scenarios/default.yaml";
// The script's own defaults; the loopback reference runs exactly these.
const std::string kWorld =
    " --set world.agents=20 --set world.anchors=6 --set world.area_m=35 --set run.steps=250 --set "
    "run.rate_hz=10";

/// Empty when namespaces and nftables are usable here, else why not.
std::string missing_prerequisite() {
  if (::geteuid() != 0) return "needs root (ip netns, nftables)";
  if (run_command("ip -V").exit_code != 0) return "needs iproute2 (`ip`)";
  if (run_command("nft --version").exit_code != 0) return "needs nftables (`nft`)";
  const std::string probe = "slmprobe" + std::to_string(::getpid());
  if (run_command("ip netns add " + probe).exit_code != 0) return "cannot create network namespaces here";
  const bool nft_ok = run_command("ip netns exec " + probe + " nft add table bridge probe").exit_code == 0;
  run_command("ip netns del " + probe);
  if (!nft_ok) return "nftables bridge tables are not available in this kernel";
  return {};
}

double final_rmse(const nlohmann::json& summary) { return summary["final"]["rmse_m"].get<double>(); }

TEST(MultiHost, TwentyAgentsOnThreeNamespaceHostsWithTenPercentWireLossMatchLoopback) {
  if (const auto why = missing_prerequisite(); !why.empty())
    GTEST_SKIP() << "multi-host test skipped: " << why;

  const auto hosts_dir = fresh_directory("multihost");
  const auto run = run_command("timeout -k 5 80 bash " + kScript + " " + kBinary + " " + hosts_dir.string() +
                               " 10 -- --set run.steps=250 --set dds.domain_id=42");
  ASSERT_TRUE(swarmloc::testing::completed_run(run.exit_code)) << run.output;
  EXPECT_NE(run.output.find("final RMSE"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("switch drops"), std::string::npos) << run.output;
  EXPECT_EQ(count_processes_matching(hosts_dir.string()), 0) << "agent processes outlived the multi-host run";
  // The script names its namespaces slm<PID>...; none may survive it.
  if (const auto at = run.output.find("namespaces slm"); at != std::string::npos) {
    const auto prefix = run.output.substr(at + 11, run.output.find('*', at) - at - 11);
    const auto list = run_command("ip netns list").output;
    EXPECT_EQ(list.find(prefix + "sw"), std::string::npos) << "namespace " << prefix << "sw left behind";
    EXPECT_EQ(list.find(prefix + "h0"), std::string::npos) << "namespace " << prefix << "h0 left behind";
  } else {
    ADD_FAILURE() << "no namespace prefix in the script's output: " << run.output;
  }

  const auto loop_dir = fresh_directory("multihost-loopback");
  const auto loop = run_command(kBinary + " run " + kScenario + " -q --out " + loop_dir.string() + kWorld +
                                " --set dds.domain_id=41");
  ASSERT_TRUE(swarmloc::testing::completed_run(loop.exit_code)) << loop.output;
  EXPECT_EQ(count_processes_matching(loop_dir.string()), 0) << "agent processes outlived the loopback run";

  const auto hosts = read_json(hosts_dir / "summary.json");
  const auto reference = read_json(loop_dir / "summary.json");
  EXPECT_EQ(hosts["agents"], 20);
  EXPECT_EQ(hosts["final"]["scored_agents"], reference["final"]["scored_agents"]);
  EXPECT_EQ(hosts["final"]["missing_agents"], 0);
  const double hosts_rmse = final_rmse(hosts);
  const double loop_rmse = final_rmse(reference);
  EXPECT_LT(hosts_rmse, 0.1) << "final RMSE across hosts must stay below the range noise std";
  EXPECT_LT(hosts_rmse, 1.5 * loop_rmse)
      << "multi-host " << hosts_rmse << " m vs loopback " << loop_rmse << " m";
  // Wire loss is below the application: nothing is injected, and most state samples still arrive.
  EXPECT_EQ(hosts["links"]["dropped_injected"], 0);
  EXPECT_GT(hosts["links"]["delivered"].get<double>(), 0.7 * hosts["links"]["sent"].get<double>());
}

TEST(MultiHost, AgentsInPodmanContainersJoinedToANamespaceHostConverge) {
  // The last host's agents run as podman containers of SWARMLOC_TEST_PODMAN_IMAGE (an image holding
  // this build: deploy/k8s/Containerfile.host-binary); skipped without it (CI has no podman).
  if (const auto why = missing_prerequisite(); !why.empty())
    GTEST_SKIP() << "multi-host test skipped: " << why;
  const char* image = std::getenv("SWARMLOC_TEST_PODMAN_IMAGE");
  if (image == nullptr || run_command("podman image exists " + std::string(image)).exit_code != 0) {
    GTEST_SKIP() << "set SWARMLOC_TEST_PODMAN_IMAGE to a podman image of this build";
  }
  const auto dir = fresh_directory("multihost-podman");
  const auto run =
      run_command("SWARMLOC_MULTIHOST_IMAGE=" + std::string(image) + " timeout -k 5 120 bash " + kScript +
                  " " + kBinary + " " + dir.string() + " 10 -- --set run.steps=250 --set dds.domain_id=43");
  ASSERT_TRUE(swarmloc::testing::completed_run(run.exit_code)) << run.output;
  EXPECT_NE(run.output.find("6 of them in podman containers"), std::string::npos) << run.output;
  const auto hosts = read_json(dir / "summary.json");
  EXPECT_EQ(hosts["final"]["missing_agents"], 0);
  EXPECT_LT(final_rmse(hosts), 0.1)
      << "final RMSE across hosts and containers must stay below the range noise";
  EXPECT_EQ(run_command("podman ps -a --format '{{.Names}}' | grep -c '^slm'").output.substr(0, 1), "0")
      << "containers left behind";
}

}  // namespace
