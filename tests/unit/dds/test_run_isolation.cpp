// Run isolation on one DDS domain (docs/robustness.md): partitions carry the run id, so one run's
// control never reaches another run's agents; a run whose fixed ports are taken is refused before it
// starts, naming the port and a free domain; estimate reports carry the agent's results hash and health,
// and absurd health figures mark a report malformed.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cmath>
#include <limits>

#include "../../../common/dds/src/wire_codec.hpp"
#include "dds_test_support.hpp"

namespace swarmloc::dds {
namespace {

using test::poll_until;

config::Scenario scenario_on(int domain_id, const std::string& run_id) {
  config::Scenario scenario;
  scenario.dds.domain_id = domain_id;
  scenario.dds.interface = "lo";
  scenario.dds.neighbour_discovery = true;
  scenario.dds.peer_address = "127.0.0.1";
  scenario.dds.run_id = run_id;
  return scenario;
}

std::vector<runtime::ControlMessage> control_taken(AgentTransport& agent, double for_s) {
  std::vector<runtime::ControlMessage> control;
  poll_until(for_s, [&] {
    auto in = agent.wait_and_take(0.05);
    control.insert(control.end(), in.control.begin(), in.control.end());
    return false;
  });
  return control;
}

TEST(RunIsolation, AnotherRunsStopNeverReachesThisRunsAgents) {
  const auto run_a = scenario_on(26, "runA");
  const auto run_b = scenario_on(26, "runB");
  OrchestratorTransport orchestrator_a(run_a, 2);
  OrchestratorTransport orchestrator_b(run_b, 2);
  AgentTransport agent_a(run_a, Topology{0, 2, {1}});
  AgentTransport agent_b(run_b, Topology{0, 2, {1}});
  ASSERT_TRUE(
      poll_until(10.0, [&] { return agent_a.orchestrator_matched() && agent_b.orchestrator_matched(); }));

  runtime::ControlMessage stop;
  stop.header = test::make_header(kOrchestratorId, 1);
  stop.command = runtime::ControlCommand::kStop;
  orchestrator_b.publish_control(stop);
  runtime::ControlMessage start = stop;
  start.command = runtime::ControlCommand::kStart;
  orchestrator_a.publish_control(start);

  const auto seen_by_a = control_taken(agent_a, 1.0);
  const auto seen_by_b = control_taken(agent_b, 0.2);
  ASSERT_EQ(seen_by_a.size(), 1U);
  EXPECT_EQ(seen_by_a[0].command, runtime::ControlCommand::kStart) << "run A's agent took run B's STOP";
  ASSERT_EQ(seen_by_b.size(), 1U);
  EXPECT_EQ(seen_by_b[0].command, runtime::ControlCommand::kStop);
}

/// Holds a UDP port as another run's participant would.
class HeldPort {
 public:
  explicit HeldPort(int port) : fd_(::socket(AF_INET, SOCK_DGRAM, 0)) {
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_ANY);
    address.sin_port = htons(static_cast<std::uint16_t>(port));
    bound_ = ::bind(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0;
  }
  ~HeldPort() { ::close(fd_); }
  HeldPort(const HeldPort&) = delete;
  HeldPort& operator=(const HeldPort&) = delete;
  [[nodiscard]] bool bound() const { return bound_; }

 private:
  int fd_;
  bool bound_ = false;
};

TEST(RunIsolation, ABusyPortOfTheRunIsRefusedNamingItsOwnerAndAFreeDomain) {
  auto scenario = scenario_on(224, "r");
  scenario.world.agents = 6;
  EXPECT_NO_THROW(require_ports_free(scenario, true));
  // Agent 3's data port on domain 224: 7400 + 250 * 224 + 10 + 2 * 3 + 1.
  const HeldPort held(7400 + 250 * 224 + 10 + 2 * 3 + 1);
  ASSERT_TRUE(held.bound());
  try {
    require_ports_free(scenario, true);
    FAIL() << "a busy port must be refused";
  } catch (const PortsInUse& error) {
    const std::string what = error.what();
    EXPECT_NE(what.find("agent 3's"), std::string::npos) << what;
    EXPECT_NE(what.find("--set dds.domain_id="), std::string::npos) << what;
  }
  // Agents started elsewhere (--no-launch): only the orchestrator's own ports are this host's to check.
  EXPECT_NO_THROW(require_ports_free(scenario, false));
  scenario.dds.neighbour_discovery = false;  // multicast discovery: no fixed ports
  EXPECT_NO_THROW(require_ports_free(scenario, true));
}

TEST(RunIsolation, EstimatesCarryTheResultsHashAndHealth) {
  runtime::EstimateReport report;
  report.header = test::make_header(3, 9);
  report.results_hash = 0xfeedfacecafebeefULL;
  report.health.ticks = 100;
  report.health.late_ticks = 7;
  report.health.missed_ticks = 2;
  report.health.max_tick_lateness_s = 0.25;
  report.health.mean_tick_lateness_s = 0.01;
  report.health.batches_received = 99;
  report.health.batches_merged = 3;
  report.health.max_batch_wait_s = 0.2;
  report.health.neighbour_age_mean_s = 0.05;
  report.health.neighbour_age_max_s = 0.4;
  const auto back = codec::round_trip(report);
  ASSERT_TRUE(back.well_formed);
  EXPECT_EQ(back.report.results_hash, report.results_hash);
  EXPECT_EQ(back.report.health.ticks, 100U);
  EXPECT_EQ(back.report.health.late_ticks, 7U);
  EXPECT_EQ(back.report.health.missed_ticks, 2U);
  EXPECT_EQ(back.report.health.max_tick_lateness_s, 0.25);
  EXPECT_EQ(back.report.health.batches_merged, 3U);
  EXPECT_EQ(back.report.health.neighbour_age_max_s, 0.4);
}

TEST(RunIsolation, AbsurdHealthFiguresMakeAReportMalformed) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int broken = 0; broken < 5; ++broken) {
    runtime::EstimateReport report;
    report.header = test::make_header(1, 1);
    report.health.ticks = 10;
    switch (broken) {
      case 0:
        report.health.max_tick_lateness_s = nan;
        break;
      case 1:
        report.health.mean_tick_lateness_s = -1.0;
        break;
      case 2:
        report.health.neighbour_age_max_s = std::numeric_limits<double>::infinity();
        break;
      case 3:
        report.health.late_ticks = 11;
        break;
      default:
        report.health.batches_merged = 1;
        break;  // more merged than received
    }
    EXPECT_FALSE(codec::round_trip(report).well_formed) << "case " << broken;
  }
}

TEST(RunIsolation, RefuseIsAControlCommand) {
  runtime::ControlMessage refusal;
  refusal.header = test::make_header(kOrchestratorId, 2);
  refusal.target = 5;
  refusal.command = runtime::ControlCommand::kRefuse;
  refusal.scenario_hash = 42;
  const auto back = codec::round_trip(refusal);
  ASSERT_TRUE(back.well_formed);
  EXPECT_EQ(back.message.command, runtime::ControlCommand::kRefuse);
  EXPECT_EQ(back.message.target, 5);
}

}  // namespace
}  // namespace swarmloc::dds
