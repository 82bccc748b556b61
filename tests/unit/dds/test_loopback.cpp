// One orchestrator and several agents in this process over real Cyclone entities on loopback.
//
// Cyclone 0.10.2 has one domain instance per domain id per process: every transport here shares the
// configuration of the first one created (DomainLease), and matching/delivery between them is local.
// Partition routing is the same as between processes; the unicast Peers discovery between processes
// is exercised by test_multiprocess.cpp. Each test uses its own domain id.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <memory>

#include "dds_test_support.hpp"

namespace swarmloc::dds {
namespace {

using test::poll_until;

config::Scenario loopback_scenario(int domain_id) {
  config::Scenario scenario;
  scenario.dds.domain_id = domain_id;
  scenario.dds.interface = "lo";
  scenario.dds.neighbour_discovery = true;
  scenario.dds.peer_address = "127.0.0.1";
  return scenario;
}

/// Accumulates everything an agent takes.
struct Collected {
  std::vector<Inbound<estimators::StateMessage>> states;
  std::vector<Inbound<estimators::InformationMessage>> information;
  std::vector<Inbound<estimators::ConsensusMessage>> consensus;
  std::vector<Inbound<estimators::BeliefMessage>> beliefs;
  std::vector<std::pair<runtime::Header, estimators::MeasurementBatch>> batches;
  std::vector<runtime::ControlMessage> control;

  void take(AgentTransport& agent, double timeout_s = 0.0) {
    auto in = agent.wait_and_take(timeout_s);
    std::move(in.states.begin(), in.states.end(), std::back_inserter(states));
    std::move(in.information.begin(), in.information.end(), std::back_inserter(information));
    std::move(in.consensus.begin(), in.consensus.end(), std::back_inserter(consensus));
    std::move(in.beliefs.begin(), in.beliefs.end(), std::back_inserter(beliefs));
    std::move(in.batches.begin(), in.batches.end(), std::back_inserter(batches));
    std::move(in.control.begin(), in.control.end(), std::back_inserter(control));
  }
  [[nodiscard]] int states_from(AgentId sender) const {
    return static_cast<int>(std::count_if(states.begin(), states.end(),
                                          [&](const auto& s) { return s.header.agent_id == sender; }));
  }
};

/// Two neighbouring agents of `algorithm` on `domain_id`, matched both ways.
struct AgentPair {
  AgentPair(const std::string& algorithm, int domain_id)
      : scenario(with_algorithm(loopback_scenario(domain_id), algorithm)),
        sender(scenario, Topology{1, 3, {2}}),
        receiver(scenario, Topology{2, 3, {1}}) {}
  static config::Scenario with_algorithm(config::Scenario scenario, const std::string& algorithm) {
    scenario.algorithm.name = algorithm;
    return scenario;
  }
  [[nodiscard]] bool matched() const {
    return sender.matched_neighbours() == 1 && receiver.matched_neighbours() == 1;
  }
  /// Once matched, publishes with `publish` until `arrived(collected)` (best effort: a sample written
  /// before the reader matched is lost); false on timeout.
  template <typename Publish, typename Arrived>
  bool deliver(Collected& collected, Publish publish, Arrived arrived) {
    return poll_until(10.0, [&] { return matched(); }) && poll_until(10.0, [&] {
             publish(sender);
             collected.take(receiver, 0.05);
             return arrived(collected);
           });
  }
  config::Scenario scenario;
  AgentTransport sender;
  AgentTransport receiver;
};

// Every inter-agent family arrives with exact values between agents of an algorithm that exchanges it; an
// agent refuses to publish a family its algorithm's registry entry does not list (it has no writer).
TEST(DdsLoopback, EachFamilyArrivesExactlyAndAnUndeclaredOneIsRefused) {
  const auto information = test::make_information(4);
  const auto consensus = test::make_consensus();
  const auto belief = test::make_belief();
  std::uint32_t seq = 0;
  const auto header = [&seq] { return test::make_header(1, seq++); };
  {
    AgentPair dle("dle", 24);  // state + information
    Collected in;
    ASSERT_TRUE(dle.deliver(
        in, [&](AgentTransport& a) { a.publish_information(header(), information); },
        [](const Collected& c) { return !c.information.empty(); }));
    EXPECT_TRUE(in.information.front().well_formed);
    test::expect_information_eq(in.information.front().message, information);
    EXPECT_THROW(dle.sender.publish_consensus(header(), consensus), DdsError);
    EXPECT_THROW(dle.sender.publish_belief(header(), belief), DdsError);
  }
  {
    AgentPair dgbb("dgbb", 25);  // state + consensus
    Collected in;
    ASSERT_TRUE(dgbb.deliver(
        in, [&](AgentTransport& a) { a.publish_consensus(header(), consensus); },
        [](const Collected& c) { return !c.consensus.empty(); }));
    EXPECT_EQ(in.consensus.front().message.values, consensus.values);
    EXPECT_EQ(in.consensus.front().message.tau, consensus.tau);
    EXPECT_THROW(dgbb.sender.publish_information(header(), information), DdsError);
  }
  {
    AgentPair bp("multipath_bp", 26);  // beliefs only
    Collected in;
    ASSERT_TRUE(bp.deliver(
        in, [&](AgentTransport& a) { a.publish_belief(header(), belief); },
        [](const Collected& c) { return !c.beliefs.empty(); }));
    EXPECT_EQ(in.beliefs.front().message.iteration, belief.iteration);
    EXPECT_MATRIX_NEAR(in.beliefs.front().message.information, belief.information, 0.0);
    ASSERT_EQ(in.beliefs.front().message.contributions.size(), belief.contributions.size());
    EXPECT_MATRIX_NEAR(in.beliefs.front().message.contributions[1].info_vec, belief.contributions[1].info_vec,
                       0.0);
    EXPECT_THROW(bp.sender.publish_state(header(), test::make_state(0.5)), DdsError);
  }
}

// The agent stops repeating its hello once the orchestrator's reader holds it: only a report written with
// that reader matched counts, since one written before never reaches it and is owed no acknowledgement.
TEST(DdsLoopback, AReportCountsAsAcknowledgedOnlyIfWrittenToAMatchedReader) {
  const auto scenario = loopback_scenario(27);
  AgentTransport agent(scenario, Topology{0, 1, {}});
  agent.publish_estimate(test::make_estimate(0, 0));
  EXPECT_FALSE(agent.reports_acknowledged());
  OrchestratorTransport orchestrator(scenario, 1);
  ASSERT_TRUE(
      poll_until(10.0, [&] { return orchestrator.matched_agents() == 1 && agent.orchestrator_matched(); }));
  // Matched now, but the report was written before: repeating it is still needed.
  EXPECT_FALSE(agent.reports_acknowledged());
  agent.publish_estimate(test::make_estimate(0, 0));
  EXPECT_TRUE(poll_until(10.0, [&] { return agent.reports_acknowledged(); }));
}

TEST(DdsLoopback, RoutesBatchesStatesAndEstimatesOnlyAlongTheTopology) {
  const auto scenario = loopback_scenario(17);
  constexpr int kAgents = 4;  // ids 1, 2, 3 run here; 1 <-> 2 are neighbours; 3 listens to 1 only
  OrchestratorTransport orchestrator(scenario, kAgents);
  AgentTransport agent1(scenario, Topology{1, kAgents, {2}});
  AgentTransport agent2(scenario, Topology{2, kAgents, {1}});
  AgentTransport agent3(scenario, Topology{3, kAgents, {1}});

  ASSERT_TRUE(poll_until(10.0,
                         [&] {
                           return agent1.matched_neighbours() == 1 && agent2.matched_neighbours() == 1 &&
                                  agent3.matched_neighbours() == 1 && agent1.orchestrator_matched() &&
                                  agent2.orchestrator_matched() && orchestrator.matched_agents() == 3;
                         }))
      << "agent1 " << agent1.matched_neighbours() << " agent2 " << agent2.matched_neighbours() << " agent3 "
      << agent3.matched_neighbours() << " orchestrator " << orchestrator.matched_agents();

  Collected in1, in2, in3;

  // Orchestrator -> agent 1 only.
  const auto batch_header = test::make_header(kOrchestratorId, 0);
  const auto batch = test::make_batch(batch_header.step, batch_header.world_stamp_ns);
  orchestrator.publish_batch(1, batch_header, batch);
  ASSERT_TRUE(poll_until(10.0, [&] {
    in1.take(agent1, 0.05);
    return !in1.batches.empty();
  }));
  ASSERT_EQ(in1.batches.size(), 1U);
  test::expect_header_eq(in1.batches[0].first, batch_header);
  test::expect_batch_eq(in1.batches[0].second, batch);
  in2.take(agent2, 0.3);
  EXPECT_TRUE(in2.batches.empty());
  EXPECT_THROW(orchestrator.publish_batch(kAgents, batch_header, batch), DdsError);

  // Agent 1 -> its neighbour 2 (and 3, which lists 1): the state family of ieif, exact values.
  const auto state = test::make_state(0.5);
  std::uint32_t seq = 0;
  ASSERT_TRUE(poll_until(10.0, [&] {
    agent1.publish_state(test::make_header(1, seq++), state);
    in2.take(agent2, 0.05);
    return !in2.states.empty();
  }));
  const auto& got_state = in2.states.front();
  EXPECT_TRUE(got_state.well_formed);
  test::expect_header_eq(got_state.header, test::make_header(1, got_state.header.seq));
  test::expect_state_eq(got_state.message, state);
  ASSERT_TRUE(poll_until(5.0, [&] {
    in3.take(agent3, 0.05);
    return in3.states_from(1) > 0;
  }));

  // Agent 3 is not a neighbour of 2 (nor listed by 1): its states reach nobody, while agent 1's
  // states, written alongside as a positive control, keep arriving.
  in1 = {};
  in2 = {};
  for (std::uint32_t k = 0; k < 25; ++k) {
    agent3.publish_state(test::make_header(3, k), test::make_state(3.0));
    agent1.publish_state(test::make_header(1, 1000 + k), state);
    in2.take(agent2, 0.02);
    in1.take(agent1, 0.0);
  }
  in2.take(agent2, 0.2);
  in1.take(agent1, 0.0);
  EXPECT_GT(in2.states_from(1), 0);
  EXPECT_EQ(in2.states_from(3), 0);
  EXPECT_EQ(in1.states_from(3), 0);

  // A sample whose header names a non-neighbour is passed on (the runtime counts unknown senders).
  in2 = {};
  ASSERT_TRUE(poll_until(5.0, [&] {
    agent1.publish_state(test::make_header(42, 7), state);
    in2.take(agent2, 0.05);
    return in2.states_from(42) > 0;
  }));
  EXPECT_TRUE(in2.states.back().well_formed);

  // Estimates from every agent reach the orchestrator with every field intact.
  std::map<AgentId, runtime::EstimateReport> reports;
  ASSERT_TRUE(poll_until(10.0, [&] {
    agent1.publish_estimate(test::make_estimate(1, 5));
    agent2.publish_estimate(test::make_estimate(2, 5));
    agent3.publish_estimate(test::make_estimate(3, 5));
    for (auto& report : orchestrator.wait_and_take_estimates(0.05)) {
      reports[report.header.agent_id] = report;
    }
    return reports.size() == 3;
  }));
  for (const AgentId id : {1, 2, 3}) {
    SCOPED_TRACE(id);
    test::expect_estimate_eq(reports.at(id), test::make_estimate(id, 5));
  }
  EXPECT_EQ(orchestrator.rejected_reports(), 0U);
}

// Above 50 agents the orchestrator writes one MeasurementBlock per block of agents (120 agents: blocks
// of 3, 40 writers instead of 120). Agents 1 and 2 share block 0 with agent 0, agent 3 opens block 1:
// each must take exactly its own batch of the step, and the hub must count all three as listening.
TEST(DdsLoopback, OneSamplePerBlockCarriesEveryAgentItsOwnBatchOnly) {
  const auto scenario = loopback_scenario(22);
  constexpr int kAgents = 120;
  OrchestratorTransport orchestrator(scenario, kAgents);
  AgentTransport agent1(scenario, Topology{1, kAgents, {}});
  AgentTransport agent2(scenario, Topology{2, kAgents, {}});
  AgentTransport agent3(scenario, Topology{3, kAgents, {}});
  ASSERT_TRUE(poll_until(10.0,
                         [&] {
                           return agent1.orchestrator_matched() && agent2.orchestrator_matched() &&
                                  agent3.orchestrator_matched() && orchestrator.agents_listening() == 3;
                         }))
      << "listening " << orchestrator.agents_listening();

  const auto header = test::make_header(kOrchestratorId, 7);
  std::vector<estimators::MeasurementBatch> batches;
  for (AgentId agent = 0; agent < kAgents; ++agent) {
    batches.push_back(test::make_batch(header.step, header.world_stamp_ns));
    batches.back().ranges.front().range_m = 100.0 + agent;  // tells the batches apart
  }
  orchestrator.publish_batches(header, batches);
  Collected in1, in2, in3;
  ASSERT_TRUE(poll_until(10.0, [&] {
    in1.take(agent1, 0.05);
    in2.take(agent2, 0.05);
    in3.take(agent3, 0.05);
    return !in1.batches.empty() && !in2.batches.empty() && !in3.batches.empty();
  }));
  in1.take(agent1, 0.2);
  for (auto [agent, in] : {std::pair{1, &in1}, std::pair{2, &in2}, std::pair{3, &in3}}) {
    ASSERT_EQ(in->batches.size(), 1U) << "agent " << agent;
    test::expect_header_eq(in->batches[0].first, header);
    test::expect_batch_eq(in->batches[0].second, batches[static_cast<std::size_t>(agent)]);
  }
  EXPECT_THROW(orchestrator.publish_batches(header, {batches.front()}), DdsError);
}

// matched_neighbours() caches its count between changes of the match status: it must still follow a
// neighbour that appears, disappears and comes back (a restarted agent is a new writer).
TEST(DdsLoopback, MatchedNeighboursFollowNeighboursThatComeGoAndComeBack) {
  const auto scenario = loopback_scenario(23);
  constexpr int kAgents = 3;
  AgentTransport agent0(scenario, Topology{0, kAgents, {1, 2}});
  EXPECT_EQ(agent0.matched_neighbours(), 0);
  auto agent1 = std::make_unique<AgentTransport>(scenario, Topology{1, kAgents, {0}});
  ASSERT_TRUE(poll_until(10.0, [&] { return agent0.matched_neighbours() == 1; }));
  auto agent2 = std::make_unique<AgentTransport>(scenario, Topology{2, kAgents, {0}});
  ASSERT_TRUE(poll_until(10.0, [&] { return agent0.matched_neighbours() == 2; }));
  agent1.reset();
  ASSERT_TRUE(poll_until(10.0, [&] { return agent0.matched_neighbours() == 1; }))
      << agent0.matched_neighbours();
  agent1 = std::make_unique<AgentTransport>(scenario, Topology{1, kAgents, {0}});
  ASSERT_TRUE(poll_until(10.0, [&] { return agent0.matched_neighbours() == 2; }))
      << agent0.matched_neighbours();
}

TEST(DdsLoopback, WaitReturnsAfterTheTimeoutWhenNothingArrives) {
  const auto scenario = loopback_scenario(20);
  AgentTransport agent(scenario, Topology{0, 1, {}});
  const auto start = std::chrono::steady_clock::now();
  const auto in = agent.wait_and_take(0.2);
  const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_TRUE(in.states.empty());
  EXPECT_TRUE(in.batches.empty());
  EXPECT_GE(waited, 0.15);
  EXPECT_LT(waited, 2.0);
  EXPECT_EQ(agent.matched_neighbours(), 0);
  EXPECT_FALSE(agent.orchestrator_matched());
}

TEST(DdsLoopback, TransientLocalControlReachesAnAgentCreatedAfterItWasWritten) {
  const auto scenario = loopback_scenario(18);
  OrchestratorTransport orchestrator(scenario, 3);
  runtime::ControlMessage start;
  start.header = test::make_header(kOrchestratorId, 4);
  start.target = kOrchestratorId;
  start.command = runtime::ControlCommand::kStart;
  start.scenario_hash = 0x0123456789abcdefULL;
  start.start_world_ns = 2'500'000'000LL;
  orchestrator.publish_control(start);

  AgentTransport late(scenario, Topology{2, 3, {1}});
  Collected in;
  ASSERT_TRUE(poll_until(10.0, [&] {
    in.take(late, 0.05);
    return !in.control.empty();
  }));
  ASSERT_EQ(in.control.size(), 1U);
  test::expect_header_eq(in.control[0].header, start.header);
  EXPECT_EQ(in.control[0].target, start.target);
  EXPECT_EQ(in.control[0].command, start.command);
  EXPECT_EQ(in.control[0].scenario_hash, start.scenario_hash);
  EXPECT_EQ(in.control[0].start_world_ns, start.start_world_ns);
}

TEST(DdsLoopback, TransportsCanBeDestroyedInAnyOrderWhileSharingADomain) {
  const auto scenario = loopback_scenario(21);
  auto orchestrator = std::make_unique<OrchestratorTransport>(scenario, 2);
  auto agent0 = std::make_unique<AgentTransport>(scenario, Topology{0, 2, {1}});
  auto agent1 = std::make_unique<AgentTransport>(scenario, Topology{1, 2, {0}});
  orchestrator.reset();  // created the domain; the agents keep it alive
  Collected in;
  ASSERT_TRUE(poll_until(10.0, [&] {
    agent0->publish_state(test::make_header(0, 1), test::make_state(0.0));
    in.take(*agent1, 0.05);
    return in.states_from(0) > 0;
  }));
  agent1.reset();
  agent0.reset();
  // The domain is gone with its last user: a new orchestrator can create it afresh.
  OrchestratorTransport again(scenario, 2);
  EXPECT_EQ(again.matched_agents(), 0);
}

}  // namespace
}  // namespace swarmloc::dds
