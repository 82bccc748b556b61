// Unicast, neighbour-scoped discovery between real processes (the in-process tests share one domain
// instance and so cannot exercise the Peers lists). The parent runs the orchestrator; each agent is this
// test binary re-executed with --gtest_filter=DdsChild.RunAgentFromEnvironment and its role in the
// environment. Agents 0 <-> 1 are neighbours; agent 2 has none.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <thread>

#include "dds_test_support.hpp"

extern char** environ;

namespace swarmloc::dds {
namespace {

constexpr const char* kChildEnv = "SWARMLOC_DDS_TEST_CHILD";
constexpr int kDomainId = 19;
constexpr int kAgents = 3;

config::Scenario multiprocess_scenario() {
  config::Scenario scenario;
  scenario.dds.domain_id = kDomainId;
  scenario.dds.interface = "lo";
  scenario.dds.neighbour_discovery = true;
  scenario.dds.peer_address = "127.0.0.1";
  return scenario;
}

std::vector<AgentId> neighbours_of(AgentId agent) {
  switch (agent) {
    case 0:
      return {1};
    case 1:
      return {0};
    default:
      return {};
  }
}

/// The agent side: publishes its state every 50 ms and an estimate every 100 ms that reports what it
/// has seen (steps_run = matched neighbours, samples_published = batches for it, links = state senders),
/// until the orchestrator sends STOP (or 30 s pass).
TEST(DdsChild, RunAgentFromEnvironment) {
  const char* role = std::getenv(kChildEnv);
  if (role == nullptr) {
    GTEST_SKIP() << "runs only as a child of DdsMultiProcess tests";
  }
  const AgentId self = std::atoi(role);
  AgentTransport transport(multiprocess_scenario(), Topology{self, kAgents, neighbours_of(self)});
  std::map<AgentId, std::uint32_t> states_from;
  std::uint32_t batches = 0;
  bool stop = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  for (std::uint32_t tick = 0; !stop && std::chrono::steady_clock::now() < deadline; ++tick) {
    transport.publish_state(test::make_header(self, tick), test::make_state(0.0));
    const auto in = transport.wait_and_take(0.05);
    for (const auto& state : in.states) {
      ++states_from[state.header.agent_id];
    }
    for (const auto& [header, batch] : in.batches) {
      batches += header.agent_id == kOrchestratorId && !batch.ranges.empty() && batch.ranges[0].peer == self;
    }
    for (const auto& control : in.control) {
      stop = stop || control.command == runtime::ControlCommand::kStop;
    }
    if (tick % 2 == 0) {
      runtime::EstimateReport report;
      report.header = test::make_header(self, tick);
      report.estimate.valid = transport.orchestrator_matched();
      report.steps_run = static_cast<std::uint32_t>(transport.matched_neighbours());
      report.samples_published = batches;
      for (const auto& [sender, count] : states_from) {
        report.links.push_back(runtime::LinkCounters{sender, count, 0, 0, 0, 0, 0});
      }
      transport.publish_estimate(report);
    }
  }
  EXPECT_TRUE(stop) << "agent " << self << " never received STOP";
}

std::set<AgentId> senders(const runtime::EstimateReport& report) {
  std::set<AgentId> out;
  for (const auto& link : report.links) {
    out.insert(link.sender);
  }
  return out;
}

TEST(DdsMultiProcess, UnicastPeersDiscoverNeighboursAndRouteOnlyTheirData) {
  const auto scenario = multiprocess_scenario();
  OrchestratorTransport orchestrator(scenario, kAgents);

  std::vector<pid_t> children;
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  for (AgentId agent = 0; agent < kAgents; ++agent) {
    std::vector<std::string> env_strings;
    for (char** e = environ; *e != nullptr; ++e) {
      if (!std::string(*e).starts_with(std::string(kChildEnv) + "=")) {
        env_strings.emplace_back(*e);
      }
    }
    env_strings.push_back(std::string(kChildEnv) + "=" + std::to_string(agent));
    std::vector<char*> envp;
    for (auto& s : env_strings) {
      envp.push_back(s.data());
    }
    envp.push_back(nullptr);
    std::string exe = "/proc/self/exe";
    std::string filter = "--gtest_filter=DdsChild.RunAgentFromEnvironment";
    std::vector<char*> argv = {exe.data(), filter.data(), nullptr};
    pid_t pid = 0;
    ASSERT_EQ(posix_spawn(&pid, exe.c_str(), &actions, nullptr, argv.data(), envp.data()), 0);
    children.push_back(pid);
  }
  posix_spawn_file_actions_destroy(&actions);

  // Feed every agent its own batches and watch the reports until each one has matched its neighbours and
  // the orchestrator, got its batches and states from every neighbour; then one more second for strays.
  std::map<AgentId, runtime::EstimateReport> latest;
  const auto done = [&] {
    if (latest.size() != kAgents) {
      return false;
    }
    for (AgentId agent = 0; agent < kAgents; ++agent) {
      const auto& report = latest.at(agent);
      const auto expected = neighbours_of(agent);
      if (!report.estimate.valid || report.samples_published == 0 || report.steps_run != expected.size() ||
          senders(report) != std::set<AgentId>(expected.begin(), expected.end())) {
        return false;
      }
    }
    return true;
  };
  std::uint32_t seq = 0;
  const auto feed = [&] {
    for (AgentId agent = 0; agent < kAgents; ++agent) {
      estimators::MeasurementBatch batch;
      batch.ranges.push_back(estimators::RangeMeasurement{agent, 1.0, 0.1});
      orchestrator.publish_batch(agent, test::make_header(kOrchestratorId, seq), batch);
    }
    ++seq;
    for (auto& report : orchestrator.wait_and_take_estimates(0.05)) {
      latest[report.header.agent_id] = report;
    }
  };
  const bool converged = test::poll_until(20.0, [&] {
    feed();
    return done();
  });
  const auto settle = std::chrono::steady_clock::now() + std::chrono::seconds(1);
  while (converged && std::chrono::steady_clock::now() < settle) {
    feed();
  }

  runtime::ControlMessage stop;
  stop.header = test::make_header(kOrchestratorId, 0);
  stop.command = runtime::ControlCommand::kStop;
  orchestrator.publish_control(stop);
  for (const pid_t pid : children) {
    int status = -1;
    const bool exited = test::poll_until(15.0, [&] { return waitpid(pid, &status, WNOHANG) == pid; });
    if (!exited) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
    }
    EXPECT_TRUE(exited) << "child " << pid << " did not exit after STOP";
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "child " << pid << " status " << status;
  }

  ASSERT_TRUE(converged) << "reports from " << latest.size() << " agents";
  for (AgentId agent = 0; agent < kAgents; ++agent) {
    SCOPED_TRACE(agent);
    const auto& report = latest.at(agent);
    const auto expected = neighbours_of(agent);
    EXPECT_TRUE(report.estimate.valid);
    EXPECT_GT(report.samples_published, 0U);
    EXPECT_EQ(report.steps_run, expected.size());
    EXPECT_EQ(senders(report), std::set<AgentId>(expected.begin(), expected.end()));
  }
  // The children deleted their participants on exit: the orchestrator sees them leave.
  EXPECT_TRUE(test::poll_until(5.0, [&] { return orchestrator.matched_agents() == 0; }));
}

}  // namespace
}  // namespace swarmloc::dds
