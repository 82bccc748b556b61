// Cyclone XML per participant (docs/design.md §4, docs/measurements/discovery.md).
//
// Port layout (Cyclone: discovery port = Base + 250 * domain_id + 10 + 2 * ParticipantIndex, data = +1;
// ParticipantIndex is limited to 0..120 by the 0.10.2 parser):
//   agent i        index i % 100, Base 7400 + 200 * (i / 100)  -> discovery port 7410 + 2 i      (+250 d)
//   orchestrator   "slot N" (N = agent count): index N % 100,
//                  Base 7400 + 200 * (N / 100)                -> discovery port 7410 + 2 N      (+250 d)
//   fusion centre  "slot N + 1" (centralized algorithms only)    -> discovery port 7410 + 2 (N + 1) (+250 d)
// The orchestrator takes the slot right after the last agent, so a run uses one contiguous block of
// 2 (N + 1) ports (2 (N + 2) with a fusion centre); for N <= 123 the blocks of different domain ids
// never overlap. The fusion centre talks to the orchestrator only: its one peer is the orchestrator,
// and the orchestrator of a centralized run lists it besides the agents.
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/dds/transport.hpp"

namespace swarmloc::dds {

namespace {

constexpr int kPortBase = 7400;
constexpr int kDomainGain = 250;
constexpr int kBlock = 100;       // participant indices per Ports/Base block
constexpr int kBlockPorts = 200;  // 2 ports per index

std::string xml_escape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

int slot_base(int slot) { return kPortBase + kBlockPorts * (slot / kBlock); }
int slot_index(int slot) { return slot % kBlock; }
int discovery_port(int slot, int domain_id) {
  return slot_base(slot) + kDomainGain * domain_id + 10 + 2 * slot_index(slot);
}

/// The run's last slot: the orchestrator's (N), or the fusion centre's (N + 1).
int last_slot_of(const config::Scenario& scenario) {
  return scenario.world.agents + (config::runs_in_fusion_centre(scenario.algorithm.name) ? 1 : 0);
}

}  // namespace

void require_ports_fit(const config::Scenario& scenario) {
  if (!scenario.dds.neighbour_discovery) return;
  const int last_slot = last_slot_of(scenario);
  const int highest = discovery_port(last_slot, scenario.dds.domain_id) + 1;  // its data port
  constexpr int kMaxPort = 65535;
  if (highest <= kMaxPort) return;
  const int largest_domain = (kMaxPort - (discovery_port(last_slot, 0) + 1)) / kDomainGain;
  throw config::ScenarioError("dds.domain_id: " + std::to_string(scenario.dds.domain_id) +
                              " with world.agents = " + std::to_string(scenario.world.agents) +
                              " puts the highest DDS port at " + std::to_string(highest) + " (> " +
                              std::to_string(kMaxPort) + "); " +
                              (largest_domain >= 0 ? "use dds.domain_id <= " + std::to_string(largest_domain)
                                                   : std::string("too many agents for fixed ports")));
}

namespace {

/// The run's fixed ports are contiguous: agent 0's discovery port up to the last slot's data port.
bool clear_of(const PortRange& range, int last_slot, int domain_id) {
  const int lowest = discovery_port(0, domain_id);
  const int highest = discovery_port(last_slot, domain_id) + 1;
  return highest <= 65535 && (highest < range.low || lowest > range.high);
}

}  // namespace

PortRange ephemeral_port_range() {
  std::ifstream in("/proc/sys/net/ipv4/ip_local_port_range");
  PortRange range;
  int low = 0;
  int high = 0;
  if (in >> low >> high && 0 < low && low <= high && high <= 65535) range = PortRange{low, high};
  return range;
}

void require_ports_clear_of(const config::Scenario& scenario, const PortRange& ephemeral) {
  if (!scenario.dds.neighbour_discovery) return;
  const int last_slot = last_slot_of(scenario);
  const int domain = scenario.dds.domain_id;
  if (clear_of(ephemeral, last_slot, domain)) return;
  int largest_below = -1;
  int smallest_above = -1;
  for (int d = 0; d <= 230; ++d) {
    if (!clear_of(ephemeral, last_slot, d)) continue;
    if (discovery_port(0, d) < ephemeral.low) largest_below = d;
    if (discovery_port(0, d) > ephemeral.high && smallest_above < 0) smallest_above = d;
  }
  std::string choices;
  if (largest_below >= 0) choices = "dds.domain_id <= " + std::to_string(largest_below);
  if (smallest_above >= 0)
    choices += (choices.empty() ? "dds.domain_id >= " : " or >= ") + std::to_string(smallest_above);
  throw config::ScenarioError(
      "dds.domain_id: " + std::to_string(domain) + " puts the run's fixed DDS ports (" +
      std::to_string(discovery_port(0, domain)) + "-" +
      std::to_string(discovery_port(last_slot, domain) + 1) + ") inside this host's ephemeral port range (" +
      std::to_string(ephemeral.low) + "-" + std::to_string(ephemeral.high) +
      ", /proc/sys/net/ipv4/ip_local_port_range), where the kernel hands them to other sockets, the "
      "participants' own transmit sockets among them, and an agent then fails to start at random; " +
      (choices.empty() ? std::string("no domain id is clear of it for this many agents") : "use " + choices));
}

namespace {

/// 0 if UDP `port` can be bound on every address now, else the errno (EADDRINUSE: someone holds it).
int udp_port_error(int port) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return errno;
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_ANY);
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  const int result = ::bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address);
  const int error = result == 0 ? 0 : errno;
  ::close(fd);
  return error;
}

struct BusyPort {
  int port = -1;  ///< -1: every port is free
  int slot = -1;
  int error = 0;
};

/// The first port of slots [first, last] on `domain_id` that cannot be bound.
BusyPort first_busy_port(int first_slot, int last_slot, int domain_id) {
  for (int slot = first_slot; slot <= last_slot; ++slot) {
    for (int offset = 0; offset < 2; ++offset) {
      const int port = discovery_port(slot, domain_id) + offset;
      if (const int error = udp_port_error(port); error != 0) return BusyPort{port, slot, error};
    }
  }
  return {};
}

}  // namespace

void require_ports_free(const config::Scenario& scenario, bool local_agents) {
  if (!scenario.dds.neighbour_discovery) return;  // multicast discovery: Cyclone picks free ports itself
  const int agents = scenario.world.agents;
  const int last_slot = last_slot_of(scenario);
  const int first_slot = local_agents ? 0 : agents;
  const BusyPort busy = first_busy_port(first_slot, last_slot, scenario.dds.domain_id);
  if (busy.port < 0) return;
  const std::string owner = busy.slot == agents       ? "the orchestrator's"
                            : busy.slot == agents + 1 ? "the fusion centre's"
                                                      : "agent " + std::to_string(busy.slot) + "'s";
  std::string message = "dds.domain_id " + std::to_string(scenario.dds.domain_id) + ": UDP port " +
                        std::to_string(busy.port) + " (" + owner +
                        " DDS port) cannot be bound: " + std::strerror(busy.error) + ". ";
  if (busy.error == EADDRINUSE) {
    message += "Another swarmloc run (or another DDS application) is using this domain. ";
    const PortRange ephemeral = ephemeral_port_range();
    for (int domain = 0; domain <= 230; ++domain) {
      if (domain == scenario.dds.domain_id || !clear_of(ephemeral, last_slot, domain)) continue;
      if (first_busy_port(first_slot, last_slot, domain).port < 0) {
        message += "Use a free domain: --set dds.domain_id=" + std::to_string(domain);
        break;
      }
    }
  }
  throw PortsInUse(message);
}

namespace {

bool is_orchestrator(const Topology& topology) { return topology.self == kOrchestratorId; }
bool is_fusion_center(const Topology& topology) { return topology.self == kFusionCenterId; }
int agent_count_of(const Topology& topology) { return topology.agent_count > 0 ? topology.agent_count : 0; }

/// <Peers>: the orchestrator lists every agent (and the fusion centre), the fusion centre the
/// orchestrator, an agent its neighbours and the orchestrator (a fusion-centre algorithm's agent, which
/// exchanges nothing with its neighbours, the orchestrator only).
void append_peers(std::ostringstream& xml, const config::Scenario& scenario, const Topology& topology) {
  const auto& dds = scenario.dds;
  const int agent_count = agent_count_of(topology);
  const std::string address = xml_escape(dds.peer_address);
  xml << "<Peers>";
  if (is_orchestrator(topology)) {
    for (int agent = 0; agent < agent_count; ++agent) {
      xml << "<Peer address=\"" << address << ':' << discovery_port(agent, dds.domain_id) << "\"/>";
    }
    if (config::runs_in_fusion_centre(scenario.algorithm.name)) {
      xml << "<Peer address=\"" << address << ':' << discovery_port(agent_count + 1, dds.domain_id) << "\"/>";
    }
  } else if (is_fusion_center(topology)) {
    xml << "<Peer address=\"" << address << ':' << discovery_port(agent_count, dds.domain_id) << "\"/>";
  } else {
    const bool sensor_only = config::runs_in_fusion_centre(scenario.algorithm.name);
    for (const AgentId neighbour : topology.neighbours) {
      if (sensor_only || neighbour == topology.self || neighbour < 0) {
        continue;
      }
      xml << "<Peer address=\"" << address << ':' << discovery_port(neighbour, dds.domain_id) << "\"/>";
    }
    xml << "<Peer address=\"" << address << ':' << discovery_port(agent_count, dds.domain_id) << "\"/>";
  }
  xml << "</Peers>";
}

/// <General> and, with neighbour discovery, <Discovery>: the interface, and this participant's fixed ports
/// and peers (or multicast discovery).
void append_general(std::ostringstream& xml, const config::Scenario& scenario, const Topology& topology) {
  const auto& dds = scenario.dds;
  const std::string interface = xml_escape(dds.interface);
  if (dds.neighbour_discovery) {
    xml << "<General><Interfaces><NetworkInterface name=\""
        << interface << "\"/></Interfaces><AllowMulticast>false</AllowMulticast></General>";
    const int agent_count = agent_count_of(topology);
    const int slot = is_orchestrator(topology)    ? agent_count
                     : is_fusion_center(topology) ? agent_count + 1
                                                  : topology.self;
    xml << "<Discovery><ParticipantIndex>" << slot_index(slot) << "</ParticipantIndex>";
    xml << "<Ports><Base>" << slot_base(slot) << "</Base></Ports>";
    append_peers(xml, scenario, topology);
    xml << "</Discovery>";
  } else {
    // Default SPDP multicast on the interface; Linux's lo lacks IFF_MULTICAST, so say it explicitly.
    xml << "<General><Interfaces><NetworkInterface name=\"" << interface << '"'
        << (dds.interface == "lo" ? " multicast=\"true\"" : "") << "/></Interfaces></General>";
  }
}

void append_internal(std::ostringstream& xml, const config::Scenario& scenario, const Topology& topology) {
  const bool orchestrator = is_orchestrator(topology);
  const bool lockstep = scenario.run.mode == config::RunMode::kLockstep;
  const bool hub = orchestrator || is_fusion_center(topology);
  xml << "<Internal>";
  if (scenario.dds.neighbour_discovery && orchestrator) {
    // Every agent sends its discovery traffic to this one socket (docs/measurements/discovery.md, "hub
    // fixes").
    xml << "<SocketReceiveBufferSize min=\"4MB\"/>";
  }
  if (!hub) {
    // One receive thread for discovery and data instead of two: hundreds of agent processes share
    // two cores, and every thread woken per datagram costs a context switch (docs/scale.md, "Start-up").
    xml << "<MultipleReceiveThreads>false</MultipleReceiveThreads>";
  }
  if (lockstep) {
    // Lockstep waits for acknowledgements every step; readers acknowledge on a writer's heartbeat,
    // and the 100 ms default made each step cost ~100 ms (5 ms: 100 steps of 30 agents in 6 s, not 15 s).
    xml << "<HeartbeatInterval min=\"1ms\" minsched=\"1ms\">5ms</HeartbeatInterval>";
  } else {
    // Free run: a built-in writer (discovery, type lookup) heartbeats to all its readers while one has
    // not acknowledged, and each heartbeat asks every reader for an ACKNACK; at the 100 ms default that
    // traffic dominated the start of hundreds of agents. Data writers write every period and repair on
    // the heartbeat that goes with their data (docs/scale.md, "Endpoints, hellos and heartbeats").
    xml << "<HeartbeatInterval>300ms</HeartbeatInterval>";
  }
  xml << "</Internal>";
}

/// DDS Security (deploy/security/README.md). No <Library> lines: Debian's libddsc finds its plugins
/// (libddsc0debian/libdds_security_{auth,ac,crypto}.so) by their default names.
void append_security(std::ostringstream& xml, const std::string& security_dir, AgentId self) {
  const SecurityFiles files = security_files(security_dir, self);
  const auto uri = [](const std::string& path) { return "file:" + xml_escape(path); };
  xml << "<Security><Authentication><IdentityCA>" << uri(files.identity_ca) << "</IdentityCA>"
      << "<IdentityCertificate>" << uri(files.certificate) << "</IdentityCertificate>"
      << "<PrivateKey>" << uri(files.private_key) << "</PrivateKey></Authentication>"
      << "<AccessControl><PermissionsCA>" << uri(files.permissions_ca) << "</PermissionsCA>"
      << "<Governance>" << uri(files.governance) << "</Governance>"
      << "<Permissions>" << uri(files.permissions) << "</Permissions></AccessControl></Security>";
}

}  // namespace

std::string cyclone_config(const config::Scenario& scenario, const Topology& topology) {
  std::ostringstream xml;
  xml << "<CycloneDDS><Domain id=\"any\">";
  append_general(xml, scenario, topology);
  append_internal(xml, scenario, topology);
  if (!scenario.dds.security_dir.empty()) append_security(xml, scenario.dds.security_dir, topology.self);
  // Warnings and errors to stderr; never a cyclonedds.log in the working directory, nothing on stdout.
  xml << "<Tracing><Verbosity>warning</Verbosity><OutputFile>stderr</OutputFile></Tracing>";
  xml << "</Domain></CycloneDDS>";

  if (const char* extra = std::getenv("SWARMLOC_CYCLONE_URI_EXTRA"); extra != nullptr && *extra != '\0') {
    // Later fragments override earlier ones (Cyclone merges a comma-separated list of XML/file URIs).
    xml << ',' << extra;
  }
  return xml.str();
}

}  // namespace swarmloc::dds
