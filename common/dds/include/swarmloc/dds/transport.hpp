#pragma once
// The DDS layer's public face. Cyclone headers are included only in common/dds/src; these classes
// hide every DDS entity behind a pimpl. Errors throw DdsError (with dds_strretcode's text).
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/runtime/envelope.hpp"

namespace swarmloc::dds {

class DdsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The fusion centre's participant id (Topology::self) and the agent id of its hello reports, which
/// tell the orchestrator it is up (its estimates carry each agent's own id).
inline constexpr AgentId kFusionCenterId = -2;

/// Who this participant is and whom it must discover.
struct Topology {
  AgentId self = kOrchestratorId;  ///< kOrchestratorId / kFusionCenterId for those roles
  int agent_count = 0;
  std::vector<AgentId> neighbours;  ///< agent: its neighbours; orchestrator: ignored (all agents)
};

/// The Cyclone XML for this participant: loopback/interface, multicast off and a Peers list of the
/// neighbours + orchestrator when scenario.dds.neighbour_discovery is on (agent i's discovery port is
/// 7410 + 2i; index i % 100 with Ports/Base shifted per block of 100 — docs/measurements/discovery.md).
/// The orchestrator takes slot N; for a centralized algorithm the fusion centre takes slot N + 1, lists
/// only the orchestrator as its peer, and the orchestrator lists it too.
std::string cyclone_config(const config::Scenario& scenario, const Topology& topology);

/// With scenario.dds.neighbour_discovery every participant has a fixed port pair (layout above); throws
/// config::ScenarioError naming dds.domain_id, with the largest domain id that fits, if the highest of
/// them (the orchestrator's, or the fusion centre's) would pass 65535.
void require_ports_fit(const config::Scenario& scenario);

/// The kernel's range of ephemeral ports (/proc/sys/net/ipv4/ip_local_port_range; Linux's default
/// 32768–60999 where that cannot be read): every Cyclone participant binds one transmit socket there.
struct PortRange {
  int low = 32768;
  int high = 60999;
};
PortRange ephemeral_port_range();

/// With scenario.dds.neighbour_discovery: throws config::ScenarioError naming dds.domain_id, and the
/// domain ids that stay clear, if the run's fixed ports overlap `ephemeral`. Any socket on the host may be
/// handed one of those ports, the participants' own transmit sockets among them, and an agent that finds
/// its port taken cannot start (docs/robustness.md, "Run isolation").
void require_ports_clear_of(const config::Scenario& scenario, const PortRange& ephemeral);

/// A run's fixed DDS ports are taken (another run on the same domain): named, with a free domain.
class PortsInUse : public DdsError {
 public:
  using DdsError::DdsError;
};

/// Before anything starts: with scenario.dds.neighbour_discovery, binds each fixed port this host will
/// use (the orchestrator's and fusion centre's, and every agent's if `local_agents`) and throws
/// PortsInUse naming the first busy one, whose participant it is, and a domain id whose ports are free.
void require_ports_free(const config::Scenario& scenario, bool local_agents);

/// One participant's DDS Security files (absolute paths) in a PKI folder made by
/// deploy/security/make-pki.sh: shared identity_ca.pem, permissions_ca.pem, governance.p7s, and the
/// participant's own folder (agent-<id>, orchestrator or fusion) with cert.pem, key.pem, permissions.p7s.
struct SecurityFiles {
  std::string identity_ca;
  std::string certificate;
  std::string private_key;
  std::string permissions_ca;
  std::string governance;
  std::string permissions;
};

/// "agent-<id>", "orchestrator" (kOrchestratorId) or "fusion" (kFusionCenterId).
std::string security_participant(AgentId self);

/// The files of participant `self` in folder `dir` (scenario key dds.security_dir). Throws
/// config::ScenarioError starting "dds.security_dir: " if the folder or one of the files is missing.
/// cyclone_config() adds a <Security> section with these files when dds.security_dir is set.
SecurityFiles security_files(const std::string& dir, AgentId self);

/// One inbound inter-agent sample before loss injection and validation (those belong to the runtime).
template <typename Message>
struct Inbound {
  runtime::Header header;
  Message message;
  bool well_formed = true;  ///< false if the wire sample had wrong sizes / bad enums (message invalid)
  std::int64_t source_timestamp_ns = 0;  ///< the writer's DDS source timestamp (real-time clock)
  std::int64_t taken_ns = 0;             ///< dds_time() when this process took it
};

/// Everything taken in one wait.
struct AgentInbound {
  std::vector<Inbound<estimators::StateMessage>> states;
  std::vector<Inbound<estimators::InformationMessage>> information;
  std::vector<Inbound<estimators::ConsensusMessage>> consensus;
  std::vector<Inbound<estimators::BeliefMessage>> beliefs;
  std::vector<Inbound<estimators::ObservationMessage>> observations;
  std::vector<std::pair<runtime::Header, estimators::MeasurementBatch>> batches;
  std::vector<runtime::ControlMessage> control;
};

/// Delivery latency of inter-agent samples: the writer's DDS source timestamp to our dds_take, both
/// read from this host's real-time clock (across hosts it includes the clocks' offset).
struct LatencySummary {
  std::size_t samples = 0;
  double p50_us = 0.0;
  double p99_us = 0.0;
};

/// Agent side: writes its own families in partition "a<id>", reads its neighbours' partitions,
/// reads its measurement batches (partition "m<id>") and control; writes estimates.
class AgentTransport {
 public:
  AgentTransport(const config::Scenario& scenario, const Topology& topology);
  ~AgentTransport();
  AgentTransport(const AgentTransport&) = delete;
  AgentTransport& operator=(const AgentTransport&) = delete;

  void publish_state(const runtime::Header& header, const estimators::StateMessage& message);
  void publish_information(const runtime::Header& header, const estimators::InformationMessage& message);
  void publish_consensus(const runtime::Header& header, const estimators::ConsensusMessage& message);
  void publish_belief(const runtime::Header& header, const estimators::BeliefMessage& message);
  /// With the state family's QoS (qos.state).
  void publish_observations(const runtime::Header& header, const estimators::ObservationMessage& message);
  /// Also, with scenario.dds.ros2, a valid estimate of a step run as a ROS 2 pose on
  /// rt/swarmloc/agent_<id>/pose (docs/ros2.md).
  void publish_estimate(const runtime::EstimateReport& report);

  /// Blocks up to timeout_s or until a control sample (lockstep: also a measurement batch) arrives, then
  /// returns every batch, control sample and neighbour sample received since the last call. Neighbour
  /// samples do not wake the caller: a listener takes them on Cyclone's receive thread as they arrive
  /// (one wake-up fewer per sample); a free-running agent takes its batches at its own tick.
  AgentInbound wait_and_take(double timeout_s);

  /// Number of neighbours whose writer of the algorithm's first sample family is currently matched
  /// (discovery progress); every neighbour when the algorithm exchanges nothing.
  [[nodiscard]] int matched_neighbours() const;
  /// Neighbour readers our writers reach (the largest count over the algorithm's family writers): a rise
  /// means a neighbour can now receive our samples (the agent re-announces its state then).
  [[nodiscard]] int matched_neighbour_readers() const;
  /// True once the orchestrator's measurement writer and control writer are both matched (the agent can
  /// receive its measurements and START).
  [[nodiscard]] bool orchestrator_matched() const;
  /// True when the last report was written with the orchestrator's estimate reader matched and every
  /// matched reader has acknowledged it (reliable QoS): the hello is in the orchestrator's reader, so
  /// repeating it would only add traffic.
  [[nodiscard]] bool reports_acknowledged() const;
  /// True once every neighbour's writers are matched to our readers and our writers to its readers
  /// (lockstep publishes its first samples only then, so no neighbour misses them).
  [[nodiscard]] bool neighbours_matched_both_ways() const;
  /// Blocks until every matched reader has acknowledged our inter-agent samples (reliable QoS), or
  /// timeout_s passes; false on timeout. Lockstep reports a step done only after this.
  bool wait_for_acks(double timeout_s);
  /// Latency of the inter-agent samples taken since START (quantiles to 2 %, constant memory).
  [[nodiscard]] LatencySummary inter_agent_latency() const;
  /// Forgets the latencies so far (the agent calls it at START: discovery-time samples are not timed).
  void reset_latency();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Orchestrator side: one measurement writer per block of agents, control writer, estimate reader.
class OrchestratorTransport {
 public:
  OrchestratorTransport(const config::Scenario& scenario, int agent_count);
  ~OrchestratorTransport();
  OrchestratorTransport(const OrchestratorTransport&) = delete;
  OrchestratorTransport& operator=(const OrchestratorTransport&) = delete;

  /// One batch, sent alone (tests, single sends); a step's batches go through publish_batches.
  void publish_batch(AgentId agent, const runtime::Header& header, const estimators::MeasurementBatch& batch);
  /// One world step: batches[i] is agent i's (size = agent count); one sample per block of agents.
  void publish_batches(const runtime::Header& header,
                       const std::vector<estimators::MeasurementBatch>& batches);
  void publish_control(const runtime::ControlMessage& message);
  /// With scenario.dds.ros2 (docs/ros2.md): the world step's truth (truth[i] = agent i, z[i] its z in a 3-D
  /// world, z empty in a planar one) as geometry_msgs/PoseArray on rt/swarmloc/truth and its ranges
  /// (batches[i] = agent i's) as swarmloc_msgs/RangeArray on rt/swarmloc/ranges, both stamped with the world
  /// time. Otherwise nothing.
  void publish_ros2_world(std::int64_t step, std::int64_t world_stamp_ns, const std::vector<Vec2>& truth,
                          const std::vector<double>& z,
                          const std::vector<estimators::MeasurementBatch>& batches);

  /// Blocks up to timeout_s, then takes every estimate report available (well-formed ones only;
  /// malformed reports are counted in rejected_reports()).
  std::vector<runtime::EstimateReport> wait_and_take_estimates(double timeout_s);
  [[nodiscard]] std::uint64_t rejected_reports() const;

  /// Agents whose estimate writer is matched.
  [[nodiscard]] int matched_agents() const;
  /// Agents whose control reader and measurement reader this orchestrator's writers have matched: START
  /// written now reaches them (the agent side is checked by AgentTransport::orchestrator_matched()).
  [[nodiscard]] int agents_listening() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// One agent's measurement batch as the fusion centre takes it.
struct FusionBatch {
  AgentId agent = 0;  ///< the batch's recipient (its topic key)
  runtime::Header header;
  estimators::MeasurementBatch batch;
};

struct FusionInbound {
  std::vector<FusionBatch> batches;
  std::vector<runtime::ControlMessage> control;
};

/// Fusion-centre side (centralized algorithms, docs/algorithms.md §2.7): reads the measurement batches of
/// every agent (partitions m0 … m<N−1>) and control; writes Estimate samples for every agent (partition
/// "est", header.agent_id = the agent the estimate is for).
class FusionTransport {
 public:
  FusionTransport(const config::Scenario& scenario, int agent_count);
  ~FusionTransport();
  FusionTransport(const FusionTransport&) = delete;
  FusionTransport& operator=(const FusionTransport&) = delete;

  /// Also, with scenario.dds.ros2, as the agent's ROS 2 pose (as AgentTransport::publish_estimate).
  void publish_estimate(const runtime::EstimateReport& report);

  /// Blocks up to timeout_s (or until data arrives), then takes everything available. Malformed
  /// batches and batches for agents outside [0, N) are dropped and counted.
  FusionInbound wait_and_take(double timeout_s);
  [[nodiscard]] std::uint64_t dropped_malformed() const;

  /// True once the orchestrator's measurement writers are matched (all N of them).
  [[nodiscard]] bool orchestrator_matched() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace swarmloc::dds
