// Multi-host run: deploy/netns/multihost.sh puts the orchestrator and 20 agent processes on four
// network namespaces ("hosts") joined by a bridge with 10 % UDP loss (nftables, in the switch's own
// namespace), Cyclone discovering by multicast on eth0. Needs root, `ip netns` and `nft`; skipped
// otherwise, failed otherwise when SWARMLOC_TEST_REQUIRE_DEPLOYMENTS=1 (CI). The same scenario on
// loopback is the reference.
// Many robots over WiFi: 60 agents on three hosts behind deploy/netns/wifi-switch.c (20 ms +- 10 ms
// per link, 5 % loss, multicast dropped), Cyclone discovering by unicast only (deploy/README.md, "Many
// robots over WiFi").
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <string>

#include "deployment_helpers.hpp"
#include "process_helpers.hpp"

namespace multihost_test {
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
    SWARMLOC_SKIP_DEPLOYMENT("multi-host test: " + why);

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
  // this build: deploy/k8s/Containerfile.host-binary, which scripts/test builds).
  if (const auto why = missing_prerequisite(); !why.empty())
    SWARMLOC_SKIP_DEPLOYMENT("multi-host test: " + why);
  if (const auto why = swarmloc::testing::missing_podman_image(); !why.empty()) SWARMLOC_SKIP_DEPLOYMENT(why);
  const std::string image = swarmloc::testing::podman_test_image();
  const auto dir = fresh_directory("multihost-podman");
  const auto run =
      run_command("SWARMLOC_MULTIHOST_IMAGE=" + image + " timeout -k 5 120 bash " + kScript + " " + kBinary +
                  " " + dir.string() + " 10 -- --set run.steps=250 --set dds.domain_id=43");
  ASSERT_TRUE(swarmloc::testing::completed_run(run.exit_code)) << run.output;
  EXPECT_NE(run.output.find("6 of them in podman containers"), std::string::npos) << run.output;
  const auto hosts = read_json(dir / "summary.json");
  EXPECT_EQ(hosts["final"]["missing_agents"], 0);
  EXPECT_LT(final_rmse(hosts), 0.1)
      << "final RMSE across hosts and containers must stay below the range noise";
  EXPECT_EQ(run_command("podman ps -a --format '{{.Names}}' | grep -c '^slm'").output.substr(0, 1), "0")
      << "containers left behind";
}

/// "multihost: all 60 agents reporting after 12.3 s" -> 12.3; NAN if absent.
double reporting_after_s(const std::string& output) {
  const auto at = output.find(" agents reporting after ");
  return at == std::string::npos ? std::nan("") : std::stod(output.substr(at + 24));
}

/// The wifi-switch's counter NAME from "wifi-switch: received R forwarded F lost L ..."; -1 if absent.
long long switch_counter(const std::string& output, const std::string& name) {
  const auto line = output.find("wifi-switch: received");
  if (line == std::string::npos) return -1;
  const auto at = output.find(" " + name + " ", line);
  return at == std::string::npos ? -1 : std::stoll(output.substr(at + name.size() + 2));
}

double delivered_fraction(const nlohmann::json& summary) {
  return summary["links"]["delivered"].get<double>() / summary["links"]["sent"].get<double>();
}

TEST(MultiHost, SixtyAgentsOnThreeHostsOverWifiLikeLinksWithUnicastDiscoveryMatchLoopback) {
  if (const auto why = missing_prerequisite(); !why.empty())
    SWARMLOC_SKIP_DEPLOYMENT("multi-host test: " + why);
  if (run_command("ethtool --version").exit_code != 0)
    SWARMLOC_SKIP_DEPLOYMENT("the WiFi-like link needs ethtool (scripts/install-deps.sh --test)");
  // 60 agents at the default scenario's density (30 in 40 m x 40 m, 8 anchors), IEIF, 10 Hz.
  const std::string world =
      " --set world.agents=60 --set world.anchors=16 --set world.area_m=56 --set run.steps=250 --set "
      "run.rate_hz=10";

  const auto hosts_dir = fresh_directory("multihost-wifi");
  const auto run = run_command(
      "SWARMLOC_MULTIHOST_LINK=wifi SWARMLOC_MULTIHOST_DELAY_MS=20 "
      "SWARMLOC_MULTIHOST_JITTER_MS=10 SWARMLOC_MULTIHOST_MANIFEST_TIMEOUT=150 "
      "SWARMLOC_MULTIHOST_SWITCH=" SWARMLOC_WIFI_SWITCH " timeout -k 5 300 bash " +
      kScript + " " + kBinary + " " + hosts_dir.string() + " 5 --" + world +
      " --set run.startup_timeout_s=150 --set dds.domain_id=57");
  ASSERT_TRUE(swarmloc::testing::completed_run(run.exit_code)) << run.output;
  EXPECT_NE(run.output.find("unicast discovery of neighbours"), std::string::npos) << run.output;
  EXPECT_EQ(count_processes_matching(hosts_dir.string()), 0) << "processes outlived the multi-host run";
  // The switch forwarded the run and lost about 5 % of what it carried; no multicast datagram reached it
  // (AllowMulticast false everywhere: discovery was unicast).
  const long long forwarded = switch_counter(run.output, "forwarded");
  const long long lost = switch_counter(run.output, "lost");
  ASSERT_GT(forwarded, 0) << run.output;
  EXPECT_GT(static_cast<double>(lost), 0.02 * static_cast<double>(forwarded + lost)) << run.output;
  EXPECT_LT(static_cast<double>(lost), 0.10 * static_cast<double>(forwarded + lost)) << run.output;
  EXPECT_EQ(switch_counter(run.output, "udp_multicast_dropped"), 0) << run.output;

  const auto loop_dir = fresh_directory("multihost-wifi-loopback");
  const auto loop = run_command(kBinary + " run " + kScenario + " -q --out " + loop_dir.string() + world +
                                " --set dds.domain_id=220");
  ASSERT_TRUE(swarmloc::testing::completed_run(loop.exit_code)) << loop.output;
  const auto hosts = read_json(hosts_dir / "summary.json");
  const auto reference = read_json(loop_dir / "summary.json");
  EXPECT_EQ(hosts["agents"], 60);
  EXPECT_EQ(hosts["final"]["missing_agents"], 0);
  EXPECT_EQ(hosts["final"]["scored_agents"], reference["final"]["scored_agents"]);
  const double hosts_rmse = final_rmse(hosts);
  const double loop_rmse = final_rmse(reference);
  EXPECT_LT(hosts_rmse, 0.1) << "final RMSE over WiFi-like links must stay below the range noise std";
  EXPECT_LT(hosts_rmse, 2.0 * loop_rmse)
      << "WiFi-like " << hosts_rmse << " m vs loopback " << loop_rmse << " m";
  // Wire loss is below the application (reliable topics repair it, best-effort state samples are lost).
  EXPECT_EQ(hosts["links"]["dropped_injected"], 0);
  EXPECT_GT(delivered_fraction(hosts), 0.8);
  std::cout << "wifi: final RMSE " << hosts_rmse << " m vs loopback " << loop_rmse << " m (ratio "
            << hosts_rmse / loop_rmse << "); delivered " << delivered_fraction(hosts) << " vs "
            << delivered_fraction(reference) << " on loopback; all agents reporting after "
            << reporting_after_s(run.output) << " s (loopback " << reporting_after_s(loop.output) << " s)\n";
}

}  // namespace
}  // namespace multihost_test
