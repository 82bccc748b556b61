#pragma once
// IDL <-> swarmloc conversion (the only place that knows both). Writes: a Wire<Family> holds the IDL
// sample plus the buffers its sequences point into; it must outlive the dds_write call and is neither
// copyable nor movable (the sample points into its own members). Reads: decode(...) never throws on bad
// content; it reports well_formed = false instead.
#include <memory>
#include <vector>

#include "swarmloc.h"
#include "wire_codec.hpp"

namespace swarmloc::dds {

runtime::Header decode_header(const swarmloc_msg_Header& wire);

struct WireState {
  WireState(const runtime::Header& header, const estimators::StateMessage& message);
  WireState(const WireState&) = delete;
  WireState& operator=(const WireState&) = delete;
  std::vector<swarmloc_msg_EdgeRange> edge_ranges;
  std::vector<swarmloc_msg_Altitude> altitude;  ///< 3-D: one entry
  std::vector<double> edge_peer_z;              ///< 3-D: one per edge range
  std::vector<swarmloc_msg_EdgeCavity> cavities;
  std::vector<double> cavity_offset_z;  ///< 3-D: one per cavity
  swarmloc_msg_State sample{};
};

struct WireInformation {
  WireInformation(const runtime::Header& header, const estimators::InformationMessage& message);
  WireInformation(const WireInformation&) = delete;
  WireInformation& operator=(const WireInformation&) = delete;
  std::vector<double> info_vec;
  std::vector<double> info_mat;
  swarmloc_msg_Information sample{};
};

struct WireConsensus {
  WireConsensus(const runtime::Header& header, const estimators::ConsensusMessage& message);
  WireConsensus(const WireConsensus&) = delete;
  WireConsensus& operator=(const WireConsensus&) = delete;
  std::vector<double> values;
  swarmloc_msg_Consensus sample{};
};

struct WireBelief {
  WireBelief(const runtime::Header& header, const estimators::BeliefMessage& message);
  WireBelief(const WireBelief&) = delete;
  WireBelief& operator=(const WireBelief&) = delete;
  std::vector<swarmloc_msg_BeliefContribution> contributions;
  swarmloc_msg_Belief sample{};
};

struct WireObservations {
  WireObservations(const runtime::Header& header, const estimators::ObservationMessage& message);
  WireObservations(const WireObservations&) = delete;
  WireObservations& operator=(const WireObservations&) = delete;
  std::vector<std::vector<swarmloc_msg_OdometrySegment>> odometry;  ///< per span
  std::vector<std::vector<swarmloc_msg_RangeBearing>> range_bearings;
  std::vector<swarmloc_msg_ObservedSpan> spans;
  swarmloc_msg_Observations sample{};
};

struct WireBatch {
  WireBatch(AgentId recipient, const runtime::Header& header, const estimators::MeasurementBatch& batch);
  WireBatch(const WireBatch&) = delete;
  WireBatch& operator=(const WireBatch&) = delete;
  std::vector<swarmloc_msg_Range> ranges;
  std::vector<swarmloc_msg_Bearing> bearings;
  std::vector<swarmloc_msg_RelativePosition> relative;
  std::vector<swarmloc_msg_TargetObservation> targets;
  std::vector<swarmloc_msg_MultipathPath> paths;
  std::vector<swarmloc_msg_AbsoluteFix> fixes;
  std::vector<double> fix_z;
  std::vector<swarmloc_msg_MotionInput> motion;
  std::vector<int32_t> neighbours;
  std::vector<swarmloc_msg_OdometrySegment> odometry;
  std::vector<swarmloc_msg_RangeBearing> range_bearings;
  swarmloc_msg_MeasurementBatch sample{};
};

/// A block of batches as one sample; the WireBatch objects own what the sample's sequences point at.
struct WireBlock {
  WireBlock(const WireBlock&) = delete;
  WireBlock& operator=(const WireBlock&) = delete;
  explicit WireBlock(int block_index) { block.block = block_index; }
  void add(AgentId recipient, const runtime::Header& header, const estimators::MeasurementBatch& batch);
  /// The sample, valid until the next add().
  const swarmloc_msg_MeasurementBlock& sample();

  std::vector<std::unique_ptr<WireBatch>> owned;
  std::vector<swarmloc_msg_MeasurementBatch> batches;
  swarmloc_msg_MeasurementBlock block{};
};

struct WireEstimate {
  explicit WireEstimate(const runtime::EstimateReport& report);
  WireEstimate(const WireEstimate&) = delete;
  WireEstimate& operator=(const WireEstimate&) = delete;
  std::vector<swarmloc_msg_LinkCounters> links;
  std::vector<uint32_t> rejected_by_reason;
  std::vector<double> field;
  std::vector<double> heading;
  std::vector<double> altitude;
  swarmloc_msg_Estimate sample{};
};

struct WireControl {
  explicit WireControl(const runtime::ControlMessage& message);
  WireControl(const WireControl&) = delete;
  WireControl& operator=(const WireControl&) = delete;
  swarmloc_msg_Control sample{};
};

Inbound<estimators::StateMessage> decode(const swarmloc_msg_State& wire);
Inbound<estimators::InformationMessage> decode(const swarmloc_msg_Information& wire);
Inbound<estimators::ConsensusMessage> decode(const swarmloc_msg_Consensus& wire);
Inbound<estimators::BeliefMessage> decode(const swarmloc_msg_Belief& wire);
Inbound<estimators::ObservationMessage> decode(const swarmloc_msg_Observations& wire);
codec::DecodedBatch decode(const swarmloc_msg_MeasurementBatch& wire);
/// Calls on_batch(DecodedBatch&&) for every batch of the block addressed to `recipient` (every batch if
/// recipient is kAnyRecipient); returns the number of those that were malformed (not passed on).
inline constexpr AgentId kAnyRecipient = -1000;
template <typename OnBatch>
std::uint64_t decode_block(const swarmloc_msg_MeasurementBlock& wire, AgentId recipient, OnBatch&& on_batch) {
  if (wire.batches._length > 0 && wire.batches._buffer == nullptr) return 1;
  std::uint64_t malformed = 0;
  for (std::uint32_t k = 0; k < wire.batches._length; ++k) {
    const swarmloc_msg_MeasurementBatch& batch = wire.batches._buffer[k];
    if (recipient != kAnyRecipient && batch.agent_id != recipient) continue;
    auto decoded = decode(batch);
    if (!decoded.well_formed) {
      ++malformed;
      continue;
    }
    on_batch(std::move(decoded));
  }
  return malformed;
}
codec::DecodedEstimate decode(const swarmloc_msg_Estimate& wire);
codec::DecodedControl decode(const swarmloc_msg_Control& wire);

}  // namespace swarmloc::dds
