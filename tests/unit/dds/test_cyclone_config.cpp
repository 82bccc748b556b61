// cyclone_config(): the XML text, and that Cyclone 0.10.2 accepts it and binds the ports we compute.
#include <dds/dds.h>
#include <dirent.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include "swarmloc/dds/transport.hpp"

namespace swarmloc::dds {
namespace {

bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

int count(const std::string& haystack, const std::string& needle) {
  int n = 0;
  for (auto pos = haystack.find(needle); pos != std::string::npos; pos = haystack.find(needle, pos + 1)) {
    ++n;
  }
  return n;
}

std::string peer(int port) { return "<Peer address=\"127.0.0.1:" + std::to_string(port) + "\"/>"; }

config::Scenario unicast_scenario(int domain_id = 0) {
  config::Scenario scenario;
  scenario.dds.domain_id = domain_id;
  scenario.dds.interface = "lo";
  scenario.dds.neighbour_discovery = true;
  scenario.dds.peer_address = "127.0.0.1";
  return scenario;
}

// Fixed ports: the highest is the orchestrator's (slot N) or the fusion centre's (slot N + 1) data port,
// 7400 + 200 (s / 100) + 250 d + 10 + 2 (s % 100) + 1. At d = 229 slot 437 is the last that fits (65535).
TEST(CycloneConfig, RunsWhoseHighestFixedPortPassesTheLastPortAreRefusedNamingTheDomain) {
  auto scenario = unicast_scenario(229);
  scenario.world.agents = 437;
  EXPECT_NO_THROW(require_ports_fit(scenario));
  scenario.algorithm.name = "ekf";  // + the fusion centre's slot
  EXPECT_THROW(require_ports_fit(scenario), config::ScenarioError);
  scenario.algorithm.name = "ieif";
  scenario.world.agents = 500;
  try {
    require_ports_fit(scenario);
    ADD_FAILURE() << "no error for d = 229, N = 500";
  } catch (const config::ScenarioError& error) {
    const std::string message = error.what();
    EXPECT_TRUE(contains(message, "dds.domain_id")) << message;
    EXPECT_TRUE(contains(message, "65661")) << message;
    EXPECT_TRUE(contains(message, "<= 228")) << message;
  }
  scenario.dds.domain_id = 228;
  EXPECT_NO_THROW(require_ports_fit(scenario));
  scenario.dds.domain_id = 229;
  scenario.dds.neighbour_discovery = false;  // Cyclone picks the ports
  EXPECT_NO_THROW(require_ports_fit(scenario));
}

// Agent i's discovery port is 7410 + 250 d + 2 i: with Linux's default ephemeral range 32768-60999, 30
// agents (ports up to the orchestrator's 7410 + 250 d + 61) fit below it up to d = 101 and above it from
// d = 215 (61160).
TEST(CycloneConfig, FixedPortsInsideTheEphemeralRangeAreRefusedNamingTheClearDomains) {
  const PortRange linux_default{32768, 60999};
  auto scenario = unicast_scenario(101);
  EXPECT_NO_THROW(require_ports_clear_of(scenario, linux_default));
  for (const int domain : {102, 177, 214}) {
    scenario.dds.domain_id = domain;
    try {
      require_ports_clear_of(scenario, linux_default);
      ADD_FAILURE() << "no error for d = " << domain;
    } catch (const config::ScenarioError& error) {
      const std::string message = error.what();
      EXPECT_TRUE(contains(message, "dds.domain_id")) << message;
      EXPECT_TRUE(contains(message, "<= 101 or >= 215")) << message;
    }
  }
  for (const int domain : {215, 230}) {
    scenario.dds.domain_id = domain;
    EXPECT_NO_THROW(require_ports_clear_of(scenario, linux_default)) << domain;
  }
  scenario.dds.domain_id = 177;
  EXPECT_NO_THROW(require_ports_clear_of(scenario, PortRange{56000, 60999}));  // its ports end at 51721
  scenario.dds.neighbour_discovery = false;  // Cyclone picks every port itself
  EXPECT_NO_THROW(require_ports_clear_of(scenario, linux_default));
}

TEST(CycloneConfig, AgentZeroListsItsNeighboursAndTheOrchestrator) {
  const auto xml = cyclone_config(unicast_scenario(), Topology{0, 30, {1, 2, 29}});
  EXPECT_TRUE(contains(xml, "<NetworkInterface name=\"lo\"/>")) << xml;
  EXPECT_TRUE(contains(xml, "<AllowMulticast>false</AllowMulticast>")) << xml;
  EXPECT_TRUE(contains(xml, "<ParticipantIndex>0</ParticipantIndex>")) << xml;
  EXPECT_TRUE(contains(xml, "<Base>7400</Base>")) << xml;
  EXPECT_TRUE(contains(xml, peer(7412))) << xml;
  EXPECT_TRUE(contains(xml, peer(7414))) << xml;
  EXPECT_TRUE(contains(xml, peer(7468))) << xml;
  EXPECT_TRUE(contains(xml, peer(7470))) << xml;  // orchestrator: slot 30 -> 7410 + 60
  EXPECT_EQ(count(xml, "<Peer "), 4) << xml;
  EXPECT_FALSE(contains(xml, "SocketReceiveBufferSize")) << xml;
}

TEST(CycloneConfig, AFusionCentreAlgorithmsAgentListsTheOrchestratorOnly) {
  auto scenario = unicast_scenario();
  scenario.algorithm.name = "ekf";  // its agents exchange nothing with their neighbours
  const auto xml = cyclone_config(scenario, Topology{0, 30, {1, 2, 29}});
  EXPECT_TRUE(contains(xml, peer(7470))) << xml;
  EXPECT_EQ(count(xml, "<Peer "), 1) << xml;
}

TEST(CycloneConfig, AgentAboveOneHundredShiftsItsPortBase) {
  const auto xml = cyclone_config(unicast_scenario(), Topology{137, 200, {136, 138, 99}});
  EXPECT_TRUE(contains(xml, "<ParticipantIndex>37</ParticipantIndex>")) << xml;
  EXPECT_TRUE(contains(xml, "<Base>7600</Base>")) << xml;  // own discovery port 7600 + 10 + 74 = 7684
  EXPECT_TRUE(contains(xml, peer(7682))) << xml;
  EXPECT_TRUE(contains(xml, peer(7686))) << xml;
  EXPECT_TRUE(contains(xml, peer(7608))) << xml;  // agent 99
  EXPECT_TRUE(contains(xml, peer(7810))) << xml;  // orchestrator: slot 200
  EXPECT_EQ(count(xml, "<Peer "), 4) << xml;
}

TEST(CycloneConfig, OrchestratorTakesTheSlotAfterTheLastAgentAndListsEveryAgent) {
  const auto xml = cyclone_config(unicast_scenario(), Topology{kOrchestratorId, 200, {}});
  EXPECT_TRUE(contains(xml, "<ParticipantIndex>0</ParticipantIndex>")) << xml;
  EXPECT_TRUE(contains(xml, "<Base>7800</Base>")) << xml;  // discovery port 7810
  EXPECT_EQ(count(xml, "<Peer "), 200) << xml;
  EXPECT_TRUE(contains(xml, peer(7410))) << xml;
  EXPECT_TRUE(contains(xml, peer(7808))) << xml;
  EXPECT_FALSE(contains(xml, peer(7810))) << xml;
  EXPECT_TRUE(contains(xml, "<SocketReceiveBufferSize min=\"4MB\"/>")) << xml;

  const auto small = cyclone_config(unicast_scenario(), Topology{kOrchestratorId, 30, {}});
  EXPECT_TRUE(contains(small, "<ParticipantIndex>30</ParticipantIndex>")) << small;
  EXPECT_TRUE(contains(small, "<Base>7400</Base>")) << small;
}

TEST(CycloneConfig, AgentsUseOneReceiveThreadAndTheOrchestratorKeepsItsOwnForData) {
  const std::string one_thread = "<MultipleReceiveThreads>false</MultipleReceiveThreads>";
  const auto agent = cyclone_config(unicast_scenario(), Topology{5, 10, {4, 6}});
  EXPECT_EQ(count(agent, one_thread), 1) << agent;
  EXPECT_EQ(count(agent, "<Internal>"), 1) << agent;
  auto lockstep = unicast_scenario();
  lockstep.run.mode = config::RunMode::kLockstep;
  const auto lockstep_agent = cyclone_config(lockstep, Topology{5, 10, {4, 6}});
  EXPECT_TRUE(contains(lockstep_agent, one_thread)) << lockstep_agent;
  EXPECT_TRUE(contains(lockstep_agent, "<HeartbeatInterval")) << lockstep_agent;
  EXPECT_EQ(count(lockstep_agent, "<Internal>"), 1) << lockstep_agent;
  const auto orchestrator = cyclone_config(unicast_scenario(), Topology{kOrchestratorId, 10, {}});
  EXPECT_FALSE(contains(orchestrator, "MultipleReceiveThreads")) << orchestrator;
}

TEST(CycloneConfig, FreeRunHeartbeatsEvery300MsAndLockstepEvery5Ms) {
  const auto free_run = cyclone_config(unicast_scenario(), Topology{5, 10, {4, 6}});
  EXPECT_EQ(count(free_run, "<HeartbeatInterval>300ms</HeartbeatInterval>"), 1) << free_run;
  const auto orchestrator = cyclone_config(unicast_scenario(), Topology{kOrchestratorId, 10, {}});
  EXPECT_EQ(count(orchestrator, "<HeartbeatInterval>300ms</HeartbeatInterval>"), 1) << orchestrator;
  auto lockstep = unicast_scenario();
  lockstep.run.mode = config::RunMode::kLockstep;
  const auto lockstep_agent = cyclone_config(lockstep, Topology{5, 10, {4, 6}});
  EXPECT_FALSE(contains(lockstep_agent, "300ms")) << lockstep_agent;
  EXPECT_TRUE(contains(lockstep_agent, ">5ms</HeartbeatInterval>")) << lockstep_agent;
}

TEST(CycloneConfig, DomainIdShiftsEveryPeerPortBy250) {
  const auto xml = cyclone_config(unicast_scenario(3), Topology{5, 10, {4}});
  EXPECT_TRUE(contains(xml, peer(7418 + 750))) << xml;
  EXPECT_TRUE(contains(xml, peer(7430 + 750))) << xml;
  EXPECT_TRUE(contains(xml, "<Base>7400</Base>")) << xml;  // Cyclone adds 250 * domain itself
}

TEST(CycloneConfig, WithoutNeighbourDiscoveryUsesMulticastAndNoPeers) {
  auto scenario = unicast_scenario();
  scenario.dds.neighbour_discovery = false;
  const auto xml = cyclone_config(scenario, Topology{3, 10, {2, 4}});
  EXPECT_FALSE(contains(xml, "Peer")) << xml;
  EXPECT_FALSE(contains(xml, "ParticipantIndex")) << xml;
  EXPECT_FALSE(contains(xml, "AllowMulticast")) << xml;
  EXPECT_TRUE(contains(xml, "<NetworkInterface name=\"lo\" multicast=\"true\"/>")) << xml;
}

TEST(CycloneConfig, AddressesAreXmlEscapedAndExtraConfigIsAppended) {
  auto scenario = unicast_scenario();
  scenario.dds.interface = "we\"ird<if>";
  EXPECT_TRUE(contains(cyclone_config(scenario, Topology{0, 2, {1}}), "name=\"we&quot;ird&lt;if&gt;\""));
  ::setenv("SWARMLOC_CYCLONE_URI_EXTRA", "<Tracing><Verbosity>config</Verbosity></Tracing>", 1);
  const auto xml = cyclone_config(unicast_scenario(), Topology{0, 2, {1}});
  ::unsetenv("SWARMLOC_CYCLONE_URI_EXTRA");
  EXPECT_TRUE(xml.ends_with("</CycloneDDS>,<Tracing><Verbosity>config</Verbosity></Tracing>")) << xml;
}

/// UDP ports of the sockets this process holds (socket inodes from /proc/self/fd, ports from /proc/net/udp).
std::set<int> own_udp_ports() {
  std::set<std::string> inodes;
  if (DIR* dir = ::opendir("/proc/self/fd")) {
    while (const dirent* entry = ::readdir(dir)) {
      char target[256] = {};
      const std::string link = std::string("/proc/self/fd/") + entry->d_name;
      const auto n = ::readlink(link.c_str(), target, sizeof(target) - 1);
      const std::string text(target, n > 0 ? static_cast<std::size_t>(n) : 0U);
      if (text.starts_with("socket:[")) {
        inodes.insert(text.substr(8, text.size() - 9));
      }
    }
    ::closedir(dir);
  }
  std::set<int> ports;
  for (const char* table : {"/proc/net/udp", "/proc/net/udp6"}) {
    std::ifstream in(table);
    std::string line;
    std::getline(in, line);  // header
    while (std::getline(in, line)) {
      std::istringstream fields(line);
      std::string slot, local, remote, state, queues, timer, retr, uid, timeout, inode;
      fields >> slot >> local >> remote >> state >> queues >> timer >> retr >> uid >> timeout >> inode;
      if (inodes.contains(inode)) {
        ports.insert(std::stoi(local.substr(local.find(':') + 1), nullptr, 16));
      }
    }
  }
  return ports;
}

/// Creates a domain from the XML (a domain id nothing else in this test binary uses) and returns the
/// ports it bound; fails the test if Cyclone refuses the configuration.
std::set<int> bound_ports(const std::string& xml, dds_domainid_t domain_id) {
  const auto before = own_udp_ports();
  const dds_entity_t domain = dds_create_domain(domain_id, xml.c_str());
  EXPECT_GT(domain, 0) << dds_strretcode(domain) << "\n" << xml;
  const dds_entity_t participant = dds_create_participant(domain_id, nullptr, nullptr);
  EXPECT_GT(participant, 0) << dds_strretcode(participant);
  std::set<int> added;
  for (const int port : own_udp_ports()) {
    if (!before.contains(port)) {
      added.insert(port);
    }
  }
  if (domain > 0) {
    dds_delete(domain);
  }
  return added;
}

TEST(CycloneConfig, CycloneAcceptsTheAgentConfigAndBindsDiscoveryPort7410Plus2i) {
  const dds_domainid_t domain_id = 41;
  const auto xml = cyclone_config(unicast_scenario(domain_id), Topology{137, 200, {136, 138}});
  const auto ports = bound_ports(xml, domain_id);
  EXPECT_TRUE(ports.contains(7684 + 250 * domain_id)) << xml;
  EXPECT_TRUE(ports.contains(7685 + 250 * domain_id)) << xml;
}

TEST(CycloneConfig, CycloneAcceptsTheOrchestratorConfigAndBindsItsSlotPort) {
  const dds_domainid_t domain_id = 42;
  const auto xml = cyclone_config(unicast_scenario(domain_id), Topology{kOrchestratorId, 200, {}});
  const auto ports = bound_ports(xml, domain_id);
  EXPECT_TRUE(ports.contains(7810 + 250 * domain_id)) << xml;
}

TEST(CycloneConfig, CycloneAcceptsTheMulticastConfig) {
  const dds_domainid_t domain_id = 43;
  auto scenario = unicast_scenario(domain_id);
  scenario.dds.neighbour_discovery = false;
  const auto ports = bound_ports(cyclone_config(scenario, Topology{1, 3, {0, 2}}), domain_id);
  EXPECT_TRUE(ports.contains(7400 + 250 * domain_id));  // SPDP multicast port
}

}  // namespace
}  // namespace swarmloc::dds
