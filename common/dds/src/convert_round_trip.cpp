// The codec's round trips: a message written into its IDL sample and decoded back, as a reader would see
// it (the unit tests and the fuzz targets; hostile variants replace one part of the sample first).
#include <utility>
#include <vector>

#include "convert.hpp"
#include "convert_support.hpp"
#include "dds/ddsi/ddsi_cdrstream.h"

namespace swarmloc::dds::codec {

using wire::point_at;
using wire::put_vec2;

Inbound<estimators::StateMessage> round_trip(const runtime::Header& header,
                                             const estimators::StateMessage& message) {
  const WireState wire(header, message);
  return decode(wire.sample);
}

Inbound<estimators::InformationMessage> round_trip(const runtime::Header& header,
                                                   const estimators::InformationMessage& message) {
  const WireInformation wire(header, message);
  return decode(wire.sample);
}

Inbound<estimators::ConsensusMessage> round_trip(const runtime::Header& header,
                                                 const estimators::ConsensusMessage& message) {
  const WireConsensus wire(header, message);
  return decode(wire.sample);
}

Inbound<estimators::BeliefMessage> round_trip(const runtime::Header& header,
                                              const estimators::BeliefMessage& message) {
  const WireBelief wire(header, message);
  return decode(wire.sample);
}

DecodedBatch round_trip(AgentId recipient, const runtime::Header& header,
                        const estimators::MeasurementBatch& batch) {
  const WireBatch wire(recipient, header, batch);
  return decode(wire.sample);
}

DecodedEstimate round_trip(const runtime::EstimateReport& report) {
  const WireEstimate wire(report);
  return decode(wire.sample);
}

DecodedControl round_trip(const runtime::ControlMessage& message) {
  const WireControl wire(message);
  return decode(wire.sample);
}

Inbound<estimators::StateMessage> round_trip_with_edge_peer_z(const runtime::Header& header,
                                                              const estimators::StateMessage& message,
                                                              std::vector<double> edge_peer_z) {
  WireState wire(header, message);
  wire.edge_peer_z = std::move(edge_peer_z);
  point_at(wire.sample.edge_peer_z, wire.edge_peer_z);
  return decode(wire.sample);
}

Inbound<estimators::StateMessage> round_trip_with_cavities(
    const runtime::Header& header, const estimators::StateMessage& message,
    const std::vector<estimators::EdgeCavity>& cavities, std::vector<double> cavity_offset_z) {
  WireState wire(header, message);
  wire.cavities.clear();
  for (const auto& cavity : cavities) {
    swarmloc_msg_EdgeCavity written{cavity.peer, {}, cavity.variance_m2};
    put_vec2(cavity.offset_m, written.offset_m);
    wire.cavities.push_back(written);
  }
  wire.cavity_offset_z = std::move(cavity_offset_z);
  point_at(wire.sample.cavities, wire.cavities);
  point_at(wire.sample.cavity_offset_z, wire.cavity_offset_z);
  return decode(wire.sample);
}

std::size_t state_xcdr1_size(const runtime::Header& header, const estimators::StateMessage& message) {
  const WireState wire(header, message);
  dds_ostream_t stream;
  dds_ostream_init(&stream, 0, CDR_ENC_VERSION_1);
  dds_stream_write(&stream, reinterpret_cast<const char*>(&wire.sample), swarmloc_msg_State_desc.m_ops);
  const std::size_t size = stream.m_index;
  dds_ostream_fini(&stream);
  return size;
}

}  // namespace swarmloc::dds::codec
