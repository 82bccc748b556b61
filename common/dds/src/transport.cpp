// AgentTransport / OrchestratorTransport over Cyclone DDS (docs/design.md §3–§4).
//
// Routing by partition (one topic per family):
//   agent i   publisher "a<i>"        : state, information, consensus, belief writers
//             publisher "est"         : estimate writer
//             subscriber a<j>…        : the four inter-agent readers (j = neighbours; "none" if none)
//             subscriber "m<b>"       : measurement reader (b = i's block);   subscriber "ctl": control
//             reader
//   orch.     publisher "m<b>" per block of agents: one measurement writer each, one MeasurementBlock
//             sample per block and step (endpoints.hpp, measurement_block_size)
//             publisher "ctl"         : control writer (transient-local per scenario.qos.control)
//             subscriber "est"        : estimate reader
// With dds.ros2 (docs/ros2.md) the agent also writes rt/swarmloc/agent_<i>/pose and the orchestrator
// rt/swarmloc/truth and rt/swarmloc/ranges, in the default partition (ros2_bridge.hpp).
// Waits: one waitset per participant with a DDS_ANY_STATE read condition per reader (triggered while
// the reader holds any sample), waited with the caller's timeout; then every reader is drained with
// loaned dds_take calls. Single-threaded use per transport object, except for the agent's four
// inter-agent readers: a data-available listener takes their samples on Cyclone's receive thread as
// they arrive, into an inbox that wait_and_take hands over. The agent thread then wakes only for its
// own tick, its measurements and control, not once per neighbour sample (docs/scale.md, "latency").
#include "swarmloc/dds/transport.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "convert.hpp"
#include "endpoints.hpp"
#include "entities.hpp"
#include "qos.hpp"
#include "ros2_bridge.hpp"
#include "swarmloc/config/algorithms.hpp"

namespace swarmloc::dds {

namespace {

/// Agent ids "j" of matched writers whose publisher has this run's partition "a<j>".
std::set<AgentId> matched_agent_partitions(dds_entity_t reader, const Partitions& partitions) {
  std::vector<dds_instance_handle_t> handles(16);
  for (;;) {
    const dds_return_t count = check(dds_get_matched_publications(reader, handles.data(), handles.size()),
                                     "dds_get_matched_publications");
    if (static_cast<std::size_t>(count) <= handles.size()) {
      handles.resize(static_cast<std::size_t>(count));
      break;
    }
    handles.resize(static_cast<std::size_t>(count));
  }
  std::set<AgentId> agents;
  for (const auto handle : handles) {
    dds_builtintopic_endpoint_t* endpoint = dds_get_matched_publication_data(reader, handle);
    if (endpoint == nullptr) {
      continue;  // unmatched in the meantime
    }
    uint32_t n = 0;
    char** names = nullptr;
    if (endpoint->qos != nullptr && dds_qget_partition(endpoint->qos, &n, &names)) {
      for (uint32_t k = 0; k < n; ++k) {
        if (const auto agent = partitions.agent_of(names[k])) agents.insert(*agent);
        dds_free(names[k]);
      }
      dds_free(static_cast<void*>(names));
    }
    dds_builtintopic_free_endpoint(endpoint);
  }
  return agents;
}

}  // namespace

// ===================================================================================================
// Agent

struct AgentTransport::Impl {
  Impl(const config::Scenario& scenario, const Topology& topology)
      : self(agent_id(topology.self)),
        neighbours(topology.neighbours),
        partitions(scenario.dds.run_id),
        algorithm(scenario.algorithm.name),
        families(config::algorithm_spec(scenario.algorithm.name).messages),
        domain(static_cast<dds_domainid_t>(scenario.dds.domain_id), cyclone_config(scenario, topology)),
        participant(create_participant(domain)) {
    const dds_entity_t pp = participant.get();
    const auto qos = effective_qos(scenario);
    const dds_entity_t t_measurements =
        create_topic(pp, swarmloc_msg_MeasurementBlock_desc, kTopicMeasurements);
    // Only the families the algorithm exchanges: each topic registers its type (and type information).
    const auto topic_if = [pp](bool used, const dds_topic_descriptor_t& descriptor, const char* name) {
      return used ? create_topic(pp, descriptor, name) : dds_entity_t{0};
    };
    const dds_entity_t t_state = topic_if(families.state, swarmloc_msg_State_desc, kTopicState);
    const dds_entity_t t_information =
        topic_if(families.information, swarmloc_msg_Information_desc, kTopicInformation);
    const dds_entity_t t_consensus =
        topic_if(families.consensus, swarmloc_msg_Consensus_desc, kTopicConsensus);
    const dds_entity_t t_belief = topic_if(families.belief, swarmloc_msg_Belief_desc, kTopicBelief);
    const dds_entity_t t_observations =
        topic_if(families.observations, swarmloc_msg_Observations_desc, kTopicObservations);
    const dds_entity_t t_estimate = create_topic(pp, swarmloc_msg_Estimate_desc, kTopicEstimate);
    const dds_entity_t t_control = create_topic(pp, swarmloc_msg_Control_desc, kTopicControl);

    const Partitions& partition_names = partitions;
    const dds_entity_t own = create_publisher(pp, {partition_names.agent(self)});
    if (families.state) state_writer = create_writer(own, t_state, qos.state, kTopicState);
    if (families.information)
      information_writer = create_writer(own, t_information, qos.information, kTopicInformation);
    if (families.consensus)
      consensus_writer = create_writer(own, t_consensus, qos.consensus, kTopicConsensus);
    if (families.belief) belief_writer = create_writer(own, t_belief, qos.belief, kTopicBelief);
    if (families.observations)
      observations_writer = create_writer(own, t_observations, qos.state, kTopicObservations);
    const dds_entity_t estimates = create_publisher(pp, {partition_names.estimates()});
    estimate_writer = create_writer(estimates, t_estimate, qos.estimate, kTopicEstimate);
    reliable_reports = qos.estimate.reliability == config::Reliability::kReliable;
    // A centralized algorithm's agents only sense: the fusion centre publishes their poses.
    if (scenario.dds.ros2 && !config::runs_in_fusion_centre(scenario.algorithm.name)) {
      ros2_pose_writer = ros2::create_writer(pp, geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc,
                                             ros2::pose_topic(self));
    }

    std::vector<std::string> neighbour_partitions;
    for (const AgentId neighbour : neighbours) {
      if (neighbour != self && neighbour >= 0) {
        neighbour_partitions.push_back(partition_names.agent(neighbour));
      }
    }
    if (neighbour_partitions.empty()) {
      neighbour_partitions.push_back(partition_names.nothing());
    }
    const dds_entity_t from_neighbours = create_subscriber(pp, neighbour_partitions);
    if (families.state) {
      state_reader = create_reader(from_neighbours, t_state, qos.state, kTopicState,
                                   inbox_listener<swarmloc_msg_State, &AgentInbound::states>().get());
    }
    if (families.information) {
      information_reader =
          create_reader(from_neighbours, t_information, qos.information, kTopicInformation,
                        inbox_listener<swarmloc_msg_Information, &AgentInbound::information>().get());
    }
    if (families.consensus) {
      consensus_reader =
          create_reader(from_neighbours, t_consensus, qos.consensus, kTopicConsensus,
                        inbox_listener<swarmloc_msg_Consensus, &AgentInbound::consensus>().get());
    }
    if (families.belief) {
      belief_reader = create_reader(from_neighbours, t_belief, qos.belief, kTopicBelief,
                                    inbox_listener<swarmloc_msg_Belief, &AgentInbound::beliefs>().get());
    }
    if (families.observations) {
      observations_reader =
          create_reader(from_neighbours, t_observations, qos.state, kTopicObservations,
                        inbox_listener<swarmloc_msg_Observations, &AgentInbound::observations>().get());
    }
    const dds_entity_t from_orchestrator = create_subscriber(
        pp, {partition_names.measurement(
                self / measurement_block_size(scenario, std::max(topology.agent_count, self + 1)))});
    measurement_reader =
        create_reader(from_orchestrator, t_measurements, qos.measurements, kTopicMeasurements);
    const dds_entity_t control = create_subscriber(pp, {partition_names.control()});
    control_reader = create_reader(control, t_control, qos.control, kTopicControl);

    waitset = check(dds_create_waitset(pp), "dds_create_waitset");
    index_families();
    attach_reader(waitset, control_reader);
    // Lockstep steps on each batch, so a batch must wake the agent. A free-running agent consumes its
    // batch at its own next tick anyway, and takes it then: one wake-up fewer per step.
    if (scenario.run.mode == config::RunMode::kLockstep) attach_reader(waitset, measurement_reader);
  }

  /// A listener whose data-available callback takes every sample of a `Wire` reader into
  /// inbox.*family (Cyclone copies the listener into the reader; deleting the reader waits for a
  /// callback in progress, and the participant is deleted before the inbox).
  template <typename Wire, auto family>
  std::unique_ptr<dds_listener_t, decltype(&dds_delete_listener)> inbox_listener() {
    std::unique_ptr<dds_listener_t, decltype(&dds_delete_listener)> listener(dds_create_listener(this),
                                                                             &dds_delete_listener);
    dds_lset_data_available(listener.get(), [](dds_entity_t reader, void* arg) {
      auto* impl = static_cast<Impl*>(arg);
      const std::lock_guard lock(impl->inbox_mutex);
      auto& samples = impl->inbox.*family;
      try {
        take_all<Wire>(
            reader,
            [&samples](const Wire& wire, std::int64_t source_ns, std::int64_t taken_ns) {
              auto decoded = decode(wire);
              decoded.source_timestamp_ns = source_ns;
              decoded.taken_ns = taken_ns;
              samples.push_back(std::move(decoded));
            },
            &impl->latencies);
      } catch (const std::exception&) {
        // No exception may unwind through Cyclone's C frames. A failed take (the reader is being
        // deleted) or allocation leaves the rest of the samples in the reader for the next callback.
      }
    });
    return listener;
  }

  /// Called once the endpoints exist: the family writers and the first family reader, which the
  /// matching and acknowledgement checks below walk (lockstep: every step).
  void index_families() {
    for (const dds_entity_t writer :
         {state_writer, information_writer, consensus_writer, belief_writer, observations_writer})
      if (writer != 0) family_writers.push_back(writer);
    for (const dds_entity_t reader :
         {state_reader, information_reader, consensus_reader, belief_reader, observations_reader}) {
      if (reader != 0) {
        first_family_reader = reader;
        break;
      }
    }
  }
  /// The writer of a family the registry entry declares; throws (naming the entry) for any other.
  dds_entity_t writer_for(dds_entity_t writer, const char* family) const {
    if (writer == 0) {
      throw DdsError(std::string("algorithm ") + algorithm + " published a " + family +
                     " sample, which its registry entry's messages do not list");
    }
    return writer;
  }

  AgentId self;
  std::vector<AgentId> neighbours;
  Partitions partitions;
  std::string algorithm;
  config::MessageFamilies families;
  std::vector<dds_entity_t> family_writers;  ///< the algorithm's family writers, in family order
  dds_entity_t first_family_reader = 0;      ///< its first family reader (0: it exchanges nothing)
  // Filled by the inter-agent readers' listeners (receive thread), emptied by wait_and_take. Declared
  // before the participant, so they outlive every reader and its listener.
  mutable std::mutex inbox_mutex;
  AgentInbound inbox;          // guarded by inbox_mutex
  LatencyHistogram latencies;  // guarded by inbox_mutex; inter-agent samples: source timestamp -> take
  DomainLease domain;          // declared before the participant: released after it
  Entity participant;          // owns every entity below
  dds_entity_t state_writer = 0, information_writer = 0, consensus_writer = 0, belief_writer = 0;
  dds_entity_t observations_writer = 0;
  dds_entity_t estimate_writer = 0;
  bool reliable_reports = false;          ///< the estimate writer is reliable (reports_acknowledged)
  bool report_written_to_reader = false;  ///< the last report was written with a reader matched
  dds_entity_t ros2_pose_writer = 0;      ///< dds.ros2 only (docs/ros2.md)
  dds_entity_t state_reader = 0, information_reader = 0, consensus_reader = 0, belief_reader = 0;
  dds_entity_t observations_reader = 0;
  dds_entity_t measurement_reader = 0, control_reader = 0;
  dds_entity_t waitset = 0;
  std::uint64_t dropped_malformed = 0;  // malformed measurement batches / control samples (not exposed yet)
  // matched_neighbours(): the count and the state reader's match status it was taken at.
  std::pair<uint32_t, int32_t> neighbours_counted_at{0, -1};
  int matched_neighbour_count = 0;
};

AgentTransport::AgentTransport(const config::Scenario& scenario, const Topology& topology)
    : impl_(std::make_unique<Impl>(scenario, topology)) {}

AgentTransport::~AgentTransport() = default;

void AgentTransport::publish_state(const runtime::Header& header, const estimators::StateMessage& message) {
  const WireState wire(header, message);
  write(impl_->writer_for(impl_->state_writer, "state"), &wire.sample, kTopicState);
}

void AgentTransport::publish_information(const runtime::Header& header,
                                         const estimators::InformationMessage& message) {
  const WireInformation wire(header, message);
  write(impl_->writer_for(impl_->information_writer, "information"), &wire.sample, kTopicInformation);
}

void AgentTransport::publish_consensus(const runtime::Header& header,
                                       const estimators::ConsensusMessage& message) {
  const WireConsensus wire(header, message);
  write(impl_->writer_for(impl_->consensus_writer, "consensus"), &wire.sample, kTopicConsensus);
}

void AgentTransport::publish_belief(const runtime::Header& header, const estimators::BeliefMessage& message) {
  const WireBelief wire(header, message);
  write(impl_->writer_for(impl_->belief_writer, "belief"), &wire.sample, kTopicBelief);
}

void AgentTransport::publish_observations(const runtime::Header& header,
                                          const estimators::ObservationMessage& message) {
  const WireObservations wire(header, message);
  write(impl_->writer_for(impl_->observations_writer, "observations"), &wire.sample, kTopicObservations);
}

void AgentTransport::publish_estimate(const runtime::EstimateReport& report) {
  const WireEstimate wire(report);
  impl_->report_written_to_reader = matched_reader_count(impl_->estimate_writer) > 0;
  write(impl_->estimate_writer, &wire.sample, kTopicEstimate);
  if (impl_->ros2_pose_writer != 0 && ros2::publishes_pose(report)) {
    const ros2::WirePose pose(report);
    write(impl_->ros2_pose_writer, &pose.sample, "ROS 2 pose");
  }
}

void AgentTransport::reset_latency() {
  const std::lock_guard lock(impl_->inbox_mutex);
  impl_->latencies.clear();
}

LatencySummary AgentTransport::inter_agent_latency() const {
  const std::lock_guard lock(impl_->inbox_mutex);
  const LatencyHistogram& histogram = impl_->latencies;
  LatencySummary summary;
  summary.samples = histogram.total();
  if (summary.samples == 0) return summary;
  summary.p50_us = histogram.quantile_us(0.50);
  summary.p99_us = histogram.quantile_us(0.99);
  return summary;
}

AgentInbound AgentTransport::wait_and_take(double timeout_s) {
  wait(impl_->waitset, timeout_s);
  AgentInbound inbound;
  {
    const std::lock_guard lock(impl_->inbox_mutex);
    std::swap(inbound, impl_->inbox);
  }
  take_all<swarmloc_msg_MeasurementBlock>(
      impl_->measurement_reader, [&](const swarmloc_msg_MeasurementBlock& wire) {
        // The block's other batches are for the other agents of our block.
        impl_->dropped_malformed += decode_block(wire, impl_->self, [&](codec::DecodedBatch&& decoded) {
          inbound.batches.emplace_back(decoded.header, std::move(decoded.batch));
        });
      });
  take_all<swarmloc_msg_Control>(impl_->control_reader, [&](const swarmloc_msg_Control& wire) {
    auto decoded = decode(wire);
    if (!decoded.well_formed) {
      ++impl_->dropped_malformed;
      return;
    }
    inbound.control.push_back(decoded.message);
  });
  return inbound;
}

int AgentTransport::matched_neighbours() const {
  const dds_entity_t reader = impl_->first_family_reader;
  if (reader == 0) return static_cast<int>(impl_->neighbours.size());  // exchanges nothing: none to wait for
  // Asked on every wake-up; reading each matched writer's QoS allocates and copies, which at N = 500 cost
  // ~50 000 calls per second across the machine. Recount only when the match status moved.
  const auto signature = matched_signature(reader);
  if (signature == impl_->neighbours_counted_at) return impl_->matched_neighbour_count;
  const auto matched = matched_agent_partitions(reader, impl_->partitions);
  impl_->matched_neighbour_count =
      static_cast<int>(std::count_if(impl_->neighbours.begin(), impl_->neighbours.end(),
                                     [&](AgentId neighbour) { return matched.contains(neighbour); }));
  impl_->neighbours_counted_at = signature;
  return impl_->matched_neighbour_count;
}

int AgentTransport::matched_neighbour_readers() const {
  int32_t most = 0;
  for (const dds_entity_t writer : impl_->family_writers) {
    most = std::max(most, matched_reader_count(writer));
  }
  return static_cast<int>(most);
}

bool AgentTransport::neighbours_matched_both_ways() const {
  const auto degree = static_cast<int32_t>(impl_->neighbours.size());
  for (const dds_entity_t writer : impl_->family_writers) {
    if (matched_reader_count(writer) < degree) return false;
  }
  return matched_neighbours() == static_cast<int>(degree);
}

bool AgentTransport::wait_for_acks(double timeout_s) {
  bool all = true;
  for (const dds_entity_t writer : impl_->family_writers) {
    const dds_return_t rc = dds_wait_for_acks(writer, to_duration(timeout_s));
    if (rc == DDS_RETCODE_TIMEOUT) {
      all = false;
    } else {
      check(rc, "dds_wait_for_acks");
    }
  }
  return all;
}

// Both of the orchestrator's writers an agent reads: with many agents the orchestrator's SEDP
// publications (N + 1 writers) reach an agent long after its one reader, so an agent could say hello
// (estimate writer matched) while its control reader had not yet seen the control writer.
bool AgentTransport::orchestrator_matched() const {
  return matched_count(impl_->control_reader) > 0 && matched_count(impl_->measurement_reader) > 0;
}

bool AgentTransport::reports_acknowledged() const {
  // A best-effort writer has nothing acknowledged: dds_wait_for_acks returns at once. A report written
  // before the orchestrator's reader matched never reaches it, and no acknowledgement is owed for it.
  if (!impl_->reliable_reports || !impl_->report_written_to_reader) return false;
  return dds_wait_for_acks(impl_->estimate_writer, 0) == DDS_RETCODE_OK;
}

// ===================================================================================================
// Orchestrator

struct OrchestratorTransport::Impl {
  Impl(const config::Scenario& scenario, int count)
      : agent_count(count >= 0 ? count : throw DdsError("OrchestratorTransport: negative agent count")),
        block_size(measurement_block_size(scenario, count)),
        domain(static_cast<dds_domainid_t>(scenario.dds.domain_id),
               cyclone_config(scenario, Topology{kOrchestratorId, count, {}})),
        participant(create_participant(domain)) {
    const dds_entity_t pp = participant.get();
    const auto qos = effective_qos(scenario);
    const dds_entity_t t_measurements =
        create_topic(pp, swarmloc_msg_MeasurementBlock_desc, kTopicMeasurements);
    const dds_entity_t t_estimate = create_topic(pp, swarmloc_msg_Estimate_desc, kTopicEstimate);
    const dds_entity_t t_control = create_topic(pp, swarmloc_msg_Control_desc, kTopicControl);

    const Partitions partition_names(scenario.dds.run_id);
    const int blocks = measurement_block_count(agent_count, block_size);
    measurement_writers.reserve(static_cast<std::size_t>(blocks));
    for (int block = 0; block < blocks; ++block) {
      const dds_entity_t publisher = create_publisher(pp, {partition_names.measurement(block)});
      measurement_writers.push_back(
          create_writer(publisher, t_measurements, qos.measurements, kTopicMeasurements));
    }
    const dds_entity_t control = create_publisher(pp, {partition_names.control()});
    control_writer = create_writer(control, t_control, qos.control, kTopicControl);
    const dds_entity_t estimates = create_subscriber(pp, {partition_names.estimates()});
    estimate_reader = create_reader(estimates, t_estimate, qos.estimate, kTopicEstimate);
    if (scenario.dds.ros2) {
      ros2_truth_writer = ros2::create_writer(pp, geometry_msgs_msg_dds__PoseArray__desc, ros2::kTruthTopic);
      ros2_ranges_writer =
          ros2::create_writer(pp, swarmloc_msgs_msg_dds__RangeArray__desc, ros2::kRangesTopic);
    }

    waitset = check(dds_create_waitset(pp), "dds_create_waitset");
    attach_reader(waitset, estimate_reader);
  }

  int agent_count;
  int block_size;                                 ///< agents per measurement block (endpoints.hpp)
  DomainLease domain;                             // declared before the participant: released after it
  Entity participant;                             // owns every entity below
  std::vector<dds_entity_t> measurement_writers;  ///< one per block of agents
  dds_entity_t control_writer = 0;
  dds_entity_t estimate_reader = 0;
  dds_entity_t ros2_truth_writer = 0, ros2_ranges_writer = 0;  ///< dds.ros2 only (docs/ros2.md)
  dds_entity_t waitset = 0;
  std::uint64_t rejected = 0;
};

OrchestratorTransport::OrchestratorTransport(const config::Scenario& scenario, int agent_count)
    : impl_(std::make_unique<Impl>(scenario, agent_count)) {}

OrchestratorTransport::~OrchestratorTransport() = default;

void OrchestratorTransport::publish_batch(AgentId agent, const runtime::Header& header,
                                          const estimators::MeasurementBatch& batch) {
  if (agent < 0 || agent >= impl_->agent_count) {
    throw DdsError("publish_batch: agent " + std::to_string(agent) + " outside [0, " +
                   std::to_string(impl_->agent_count) + ")");
  }
  const auto writer = agent / impl_->block_size;
  WireBlock block(writer);
  block.add(agent, header, batch);
  write(impl_->measurement_writers[static_cast<std::size_t>(writer)], &block.sample(), kTopicMeasurements);
}

void OrchestratorTransport::publish_batches(const runtime::Header& header,
                                            const std::vector<estimators::MeasurementBatch>& batches) {
  if (batches.size() != static_cast<std::size_t>(impl_->agent_count)) {
    throw DdsError("publish_batches: " + std::to_string(batches.size()) + " batches for " +
                   std::to_string(impl_->agent_count) + " agents");
  }
  const int block_size = impl_->block_size;
  for (std::size_t writer = 0; writer < impl_->measurement_writers.size(); ++writer) {
    WireBlock block(static_cast<int>(writer));
    const int first = static_cast<int>(writer) * block_size;
    for (AgentId agent = first; agent < std::min(first + block_size, impl_->agent_count); ++agent) {
      block.add(agent, header, batches[static_cast<std::size_t>(agent)]);
    }
    write(impl_->measurement_writers[writer], &block.sample(), kTopicMeasurements);
  }
}

void OrchestratorTransport::publish_ros2_world(std::int64_t step, std::int64_t world_stamp_ns,
                                               const std::vector<Vec2>& truth, const std::vector<double>& z,
                                               const std::vector<estimators::MeasurementBatch>& batches) {
  if (impl_->ros2_truth_writer == 0) return;
  const ros2::WirePoseArray poses(world_stamp_ns, truth, z);
  write(impl_->ros2_truth_writer, &poses.sample, "ROS 2 truth");
  const ros2::WireRangeArray ranges(step, world_stamp_ns, batches);
  write(impl_->ros2_ranges_writer, &ranges.sample, "ROS 2 ranges");
}

void OrchestratorTransport::publish_control(const runtime::ControlMessage& message) {
  const WireControl wire(message);
  write(impl_->control_writer, &wire.sample, kTopicControl);
}

std::vector<runtime::EstimateReport> OrchestratorTransport::wait_and_take_estimates(double timeout_s) {
  wait(impl_->waitset, timeout_s);
  std::vector<runtime::EstimateReport> reports;
  take_all<swarmloc_msg_Estimate>(impl_->estimate_reader, [&](const swarmloc_msg_Estimate& wire) {
    auto decoded = decode(wire);
    if (!decoded.well_formed) {
      ++impl_->rejected;
      return;
    }
    reports.push_back(std::move(decoded.report));
  });
  return reports;
}

std::uint64_t OrchestratorTransport::rejected_reports() const { return impl_->rejected; }

int OrchestratorTransport::matched_agents() const { return matched_count(impl_->estimate_reader); }

int OrchestratorTransport::agents_listening() const {
  // Each agent has one reader on its block's writer (a fusion centre reads every block: with one, a
  // block's count can include it, hence the cap at the block's size).
  const int block_size = impl_->block_size;
  int listening = 0;
  for (std::size_t writer = 0; writer < impl_->measurement_writers.size(); ++writer) {
    const int first = static_cast<int>(writer) * block_size;
    const int in_block = std::min(block_size, impl_->agent_count - first);
    listening +=
        std::min(in_block, static_cast<int>(matched_reader_count(impl_->measurement_writers[writer])));
  }
  return std::min(listening, static_cast<int>(matched_reader_count(impl_->control_writer)));
}

}  // namespace swarmloc::dds
