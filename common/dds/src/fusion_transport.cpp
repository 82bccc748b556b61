// FusionTransport over Cyclone DDS (docs/design.md §1, docs/algorithms.md §2.7).
//
//   fusion centre  subscriber "m0" … "m<N−1>" : one measurement reader for every agent's batches
//                  subscriber "ctl"           : control reader
//                  publisher  "est"           : estimate writer (one instance per agent id)
// Discovery: slot N + 1, the orchestrator (slot N) as its only peer (cyclone_config.cpp).
#include <string>
#include <vector>

#include "convert.hpp"
#include "endpoints.hpp"
#include "entities.hpp"
#include "qos.hpp"
#include "ros2_bridge.hpp"
#include "swarmloc/dds/transport.hpp"

namespace swarmloc::dds {

struct FusionTransport::Impl {
  Impl(const config::Scenario& scenario, int count)
      : agent_count(count > 0 ? count : throw DdsError("FusionTransport: agent count must be positive")),
        block_size(measurement_block_size(scenario, count)),
        domain(static_cast<dds_domainid_t>(scenario.dds.domain_id),
               cyclone_config(scenario, Topology{kFusionCenterId, count, {}})),
        participant(create_participant(domain)) {
    const dds_entity_t pp = participant.get();
    const auto qos = effective_qos(scenario);
    const dds_entity_t t_measurements =
        create_topic(pp, swarmloc_msg_MeasurementBlock_desc, kTopicMeasurements);
    const dds_entity_t t_estimate = create_topic(pp, swarmloc_msg_Estimate_desc, kTopicEstimate);
    const dds_entity_t t_control = create_topic(pp, swarmloc_msg_Control_desc, kTopicControl);

    const Partitions partition_names(scenario.dds.run_id);
    const int block_count = measurement_block_count(agent_count, block_size);
    std::vector<std::string> partitions;
    partitions.reserve(static_cast<std::size_t>(block_count));
    for (int block = 0; block < block_count; ++block)
      partitions.push_back(partition_names.measurement(block));
    const dds_entity_t measurements = create_subscriber(pp, partitions);
    measurement_reader = create_reader(measurements, t_measurements, qos.measurements, kTopicMeasurements);
    const dds_entity_t control = create_subscriber(pp, {partition_names.control()});
    control_reader = create_reader(control, t_control, qos.control, kTopicControl);
    const dds_entity_t estimates = create_publisher(pp, {partition_names.estimates()});
    estimate_writer = create_writer(estimates, t_estimate, qos.estimate, kTopicEstimate);
    if (scenario.dds.ros2) {  // the fusion centre estimates every agent: it publishes every agent's pose
      for (AgentId agent = 0; agent < agent_count; ++agent) {
        ros2_pose_writers.push_back(ros2::create_writer(
            pp, geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc, ros2::pose_topic(agent)));
      }
    }

    waitset = check(dds_create_waitset(pp), "dds_create_waitset");
    attach_reader(waitset, measurement_reader);
    attach_reader(waitset, control_reader);
  }

  int agent_count;
  int block_size;      ///< agents per measurement block (endpoints.hpp)
  DomainLease domain;  // declared before the participant: released after it
  Entity participant;  // owns every entity below
  dds_entity_t measurement_reader = 0, control_reader = 0;
  dds_entity_t estimate_writer = 0;
  std::vector<dds_entity_t> ros2_pose_writers;  ///< dds.ros2 only: agent i's at [i]
  dds_entity_t waitset = 0;
  std::uint64_t dropped_malformed = 0;
};

FusionTransport::FusionTransport(const config::Scenario& scenario, int agent_count)
    : impl_(std::make_unique<Impl>(scenario, agent_count)) {}

FusionTransport::~FusionTransport() = default;

void FusionTransport::publish_estimate(const runtime::EstimateReport& report) {
  const WireEstimate wire(report);
  write(impl_->estimate_writer, &wire.sample, kTopicEstimate);
  const AgentId agent = report.header.agent_id;
  if (agent >= 0 && static_cast<std::size_t>(agent) < impl_->ros2_pose_writers.size() &&
      ros2::publishes_pose(report)) {
    const ros2::WirePose pose(report);
    write(impl_->ros2_pose_writers[static_cast<std::size_t>(agent)], &pose.sample, "ROS 2 pose");
  }
}

FusionInbound FusionTransport::wait_and_take(double timeout_s) {
  wait(impl_->waitset, timeout_s);
  FusionInbound inbound;
  take_all<swarmloc_msg_MeasurementBlock>(
      impl_->measurement_reader, [&](const swarmloc_msg_MeasurementBlock& wire) {
        impl_->dropped_malformed += decode_block(wire, kAnyRecipient, [&](codec::DecodedBatch&& decoded) {
          if (decoded.recipient < 0 || decoded.recipient >= impl_->agent_count) {
            ++impl_->dropped_malformed;
            return;
          }
          inbound.batches.push_back(FusionBatch{decoded.recipient, decoded.header, std::move(decoded.batch)});
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

std::uint64_t FusionTransport::dropped_malformed() const { return impl_->dropped_malformed; }

bool FusionTransport::orchestrator_matched() const {
  return matched_count(impl_->measurement_reader) >=
         measurement_block_count(impl_->agent_count, impl_->block_size);
}

}  // namespace swarmloc::dds
