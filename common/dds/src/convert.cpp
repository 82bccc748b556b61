// IDL samples (swarmloc.h) <-> swarmloc types (convert.hpp); OBSERVATIONS in convert_observations.cpp.
#include "convert.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "convert_support.hpp"
#include "dds/ddsi/ddsi_cdrstream.h"
#include "swarmloc/core/gaussian.hpp"

namespace swarmloc::dds {

using wire::encode_header;
using wire::get_sym2;
using wire::get_vec2;
using wire::point_at;
using wire::put_sym2;
using wire::put_vec2;
using wire::range_bearing_of;
using wire::view;
using wire::wire_range_bearing;

// ---------------------------------------------------------------------------------------------------
// Field-level rules (wire_codec.hpp)

namespace codec {

std::array<double, 3> pack_sym2(const Mat2& matrix) { return {matrix(0, 0), matrix(0, 1), matrix(1, 1)}; }

Mat2 unpack_sym2(std::span<const double, 3> packed) {
  Mat2 matrix;
  matrix << packed[0], packed[1], packed[1], packed[2];
  return matrix;
}

std::vector<double> pack_upper(const MatX& matrix) {
  const auto n = matrix.rows();
  std::vector<double> packed;
  packed.reserve(static_cast<std::size_t>(n * (n + 1) / 2));
  for (Eigen::Index row = 0; row < n; ++row) {
    for (Eigen::Index col = row; col < n; ++col) {
      packed.push_back(matrix(row, col));
    }
  }
  return packed;
}

std::optional<MatX> unpack_upper(std::span<const double> packed, std::size_t n) {
  if (packed.size() != n * (n + 1) / 2) {
    return std::nullopt;
  }
  const auto dim = static_cast<Eigen::Index>(n);
  MatX matrix(dim, dim);
  std::size_t next = 0;
  for (Eigen::Index row = 0; row < dim; ++row) {
    for (Eigen::Index col = row; col < dim; ++col) {
      matrix(row, col) = packed[next];
      matrix(col, row) = packed[next];
      ++next;
    }
  }
  return matrix;
}

bool plausible_altitude(const Mat2& planar_covariance, const Altitude& altitude) {
  if (!std::isfinite(altitude.z_m) || !std::isfinite(altitude.variance_m2) ||
      !altitude.cross_m2.allFinite() || altitude.variance_m2 < 0.0) {
    return false;
  }
  return core::is_symmetric_psd_dynamic(MatX(join(planar_covariance, altitude)), 1e-9);
}

std::uint8_t state_flags(const estimators::StateMessage& message) {
  return static_cast<std::uint8_t>((message.anchor ? kStateFlagAnchor : 0) |
                                   (message.active ? kStateFlagActive : 0) |
                                   (message.inconsistent ? kStateFlagInconsistent : 0));
}

bool apply_state_flags(std::uint8_t flags, estimators::StateMessage& message) {
  if ((flags & ~kStateFlagsKnown) != 0) {
    return false;
  }
  message.anchor = (flags & kStateFlagAnchor) != 0;
  message.active = (flags & kStateFlagActive) != 0;
  message.inconsistent = (flags & kStateFlagInconsistent) != 0;
  return true;
}

std::optional<runtime::ControlCommand> control_command(std::uint8_t wire) {
  switch (wire) {
    case swarmloc_msg_CONTROL_HELLO:
      return runtime::ControlCommand::kHello;
    case swarmloc_msg_CONTROL_START:
      return runtime::ControlCommand::kStart;
    case swarmloc_msg_CONTROL_STOP:
      return runtime::ControlCommand::kStop;
    case swarmloc_msg_CONTROL_REFUSE:
      return runtime::ControlCommand::kRefuse;
    default:
      return std::nullopt;
  }
}

Inbound<estimators::InformationMessage> decode_information_fields(const runtime::Header& header, AgentId key,
                                                                  std::int32_t target,
                                                                  std::span<const double> info_vec,
                                                                  std::span<const double> info_mat) {
  Inbound<estimators::InformationMessage> inbound;
  inbound.header = header;
  inbound.message.target = target;
  if (key != header.agent_id || info_vec.size() > kMaxInfoDim || info_mat.size() > kMaxInfoMat) {
    inbound.well_formed = false;
    return inbound;
  }
  auto matrix = unpack_upper(info_mat, info_vec.size());
  if (!matrix) {
    inbound.well_formed = false;
    return inbound;
  }
  inbound.message.info_vec =
      Eigen::Map<const VecX>(info_vec.data(), static_cast<Eigen::Index>(info_vec.size()));
  inbound.message.info_mat = std::move(*matrix);
  return inbound;
}

}  // namespace codec

// ---------------------------------------------------------------------------------------------------
// Writes

WireState::WireState(const runtime::Header& header, const estimators::StateMessage& message) {
  sample.agent_id = header.agent_id;
  sample.header = encode_header(header);
  put_vec2(message.mean_m, sample.mean_m);
  put_sym2(message.covariance, sample.covariance);
  sample.flags = codec::state_flags(message);
  sample.degree = message.degree;
  if (message.edge_ranges.size() > codec::kMaxEdgeRanges) {
    throw DdsError("publish_state: " + std::to_string(message.edge_ranges.size()) +
                   " edge ranges (IDL bound 16)");
  }
  edge_ranges.reserve(message.edge_ranges.size());
  for (const auto& edge : message.edge_ranges) {
    swarmloc_msg_EdgeRange wire{edge.peer, edge.information, edge.mean_range_m, {}};
    put_vec2(edge.peer_mean_m, wire.peer_mean_m);
    edge_ranges.push_back(wire);
  }
  point_at(sample.edge_ranges, edge_ranges);
  if (const auto& z = message.altitude) {  // 3-D: the z part, and the z of every edge's peer mean
    swarmloc_msg_Altitude wire{z->z_m, z->variance_m2, {}};
    put_vec2(z->cross_m2, wire.cross_m2);
    altitude.push_back(wire);
    for (const auto& edge : message.edge_ranges) edge_peer_z.push_back(edge.peer_z_m);
  }
  point_at(sample.altitude, altitude);
  point_at(sample.edge_peer_z, edge_peer_z);
  if (message.cavities.size() > codec::kMaxCavities) {
    throw DdsError("publish_state: " + std::to_string(message.cavities.size()) + " cavities (IDL bound 64)");
  }
  cavities.reserve(message.cavities.size());
  for (const auto& cavity : message.cavities) {
    swarmloc_msg_EdgeCavity wire{cavity.peer, {}, cavity.variance_m2};
    put_vec2(cavity.offset_m, wire.offset_m);
    cavities.push_back(wire);
    if (message.altitude) cavity_offset_z.push_back(cavity.offset_z_m);  // 3-D only, like edge_peer_z
  }
  point_at(sample.cavities, cavities);
  point_at(sample.cavity_offset_z, cavity_offset_z);
}

WireInformation::WireInformation(const runtime::Header& header,
                                 const estimators::InformationMessage& message) {
  const auto n = message.info_vec.size();
  if (static_cast<std::size_t>(n) > codec::kMaxInfoDim) {
    throw DdsError("publish_information: info_vec has " + std::to_string(n) + " entries (IDL bound 64)");
  }
  if (message.info_mat.rows() != n || message.info_mat.cols() != n) {
    throw DdsError("publish_information: info_mat is " + std::to_string(message.info_mat.rows()) + "x" +
                   std::to_string(message.info_mat.cols()) + ", info_vec has " + std::to_string(n) +
                   " entries");
  }
  info_vec.assign(message.info_vec.data(), message.info_vec.data() + n);
  info_mat = codec::pack_upper(message.info_mat);
  sample.agent_id = header.agent_id;
  sample.header = encode_header(header);
  sample.target = message.target;
  sample.world_step = message.world_step;
  point_at(sample.info_vec, info_vec);
  point_at(sample.info_mat, info_mat);
}

WireConsensus::WireConsensus(const runtime::Header& header, const estimators::ConsensusMessage& message)
    : values(message.values) {
  if (values.size() > codec::kMaxConsensusValues) {
    throw DdsError("publish_consensus: " + std::to_string(values.size()) + " values (IDL bound 16)");
  }
  sample.agent_id = header.agent_id;
  sample.header = encode_header(header);
  sample.tau = message.tau;
  sample.round = message.round;
  point_at(sample.values, values);
}

WireBelief::WireBelief(const runtime::Header& header, const estimators::BeliefMessage& message) {
  sample.agent_id = header.agent_id;
  sample.header = encode_header(header);
  sample.iteration = message.iteration;
  put_vec2(message.mean_m, sample.mean_m);
  put_sym2(message.information, sample.information);
  sample.infinite_information = message.infinite_information;
  if (message.contributions.size() > codec::kMaxBeliefContributions) {
    throw DdsError("publish_belief: " + std::to_string(message.contributions.size()) +
                   " contributions (IDL bound 1024)");
  }
  contributions.reserve(message.contributions.size());
  for (const auto& c : message.contributions) {
    swarmloc_msg_BeliefContribution wire{};
    wire.from = c.from;
    put_vec2(c.info_vec, wire.info_vec);
    put_sym2(c.information, wire.information);
    contributions.push_back(wire);
  }
  point_at(sample.contributions, contributions);
}

WireBatch::WireBatch(AgentId recipient, const runtime::Header& header,
                     const estimators::MeasurementBatch& batch) {
  ranges.reserve(batch.ranges.size());
  for (const auto& range : batch.ranges) {
    ranges.push_back(swarmloc_msg_Range{range.peer, range.range_m, range.std_m});
  }
  for (const auto& bearing : batch.bearings) {
    bearings.push_back(swarmloc_msg_Bearing{bearing.peer, bearing.bearing_rad, bearing.std_rad});
  }
  for (const auto& m : batch.relative) {
    swarmloc_msg_RelativePosition wire{};
    wire.peer = m.peer;
    put_vec2(m.delta_m, wire.delta_m);
    put_sym2(m.covariance, wire.covariance);
    relative.push_back(wire);
  }
  for (const auto& m : batch.targets) {
    swarmloc_msg_TargetObservation wire{};
    wire.target = m.target;
    put_vec2(m.value, wire.value);
    put_sym2(m.covariance, wire.covariance);
    wire.kind = m.kind;
    targets.push_back(wire);
  }
  for (const auto& m : batch.paths) {
    if (m.path_index < 0 || m.path_index > 255) {
      throw DdsError("publish_batch: path_index " + std::to_string(m.path_index) +
                     " does not fit the IDL's uint8");
    }
    paths.push_back(swarmloc_msg_MultipathPath{m.peer, static_cast<uint8_t>(m.path_index), m.length_m,
                                               m.aoa_here_rad, m.aoa_there_rad});
  }
  if (batch.fix) {
    swarmloc_msg_AbsoluteFix fix{};
    put_vec2(batch.fix->position_m, fix.position_m);
    put_sym2(batch.fix->covariance, fix.covariance);
    fixes.push_back(fix);
    if (batch.fix->z_m) fix_z.push_back(*batch.fix->z_m);
  }
  if (batch.motion) {
    swarmloc_msg_MotionInput input{};
    put_vec2(batch.motion->velocity_mps, input.velocity_mps);
    input.dt_s = batch.motion->dt_s;
    put_sym2(batch.motion->process_cov, input.process_cov);
    motion.push_back(input);
  }
  neighbours.assign(batch.neighbours.begin(), batch.neighbours.end());
  if (batch.odometry) {
    for (const auto& segment : batch.odometry->segments) {
      odometry.push_back(swarmloc_msg_OdometrySegment{segment.v_mps, segment.omega_radps, segment.dt_s});
    }
    sample.has_odometry = true;
    sample.odometry_v_std = batch.odometry->v_std;
    sample.odometry_omega_std = batch.odometry->omega_std;
  }
  for (const auto& m : batch.range_bearings) range_bearings.push_back(wire_range_bearing(m));
  point_at(sample.odometry, odometry);
  point_at(sample.range_bearings, range_bearings);
  sample.agent_id = recipient;
  sample.header = encode_header(header);
  sample.world_time_s = batch.world_time_s;
  point_at(sample.ranges, ranges);
  point_at(sample.bearings, bearings);
  point_at(sample.relative, relative);
  point_at(sample.targets, targets);
  point_at(sample.paths, paths);
  point_at(sample.fixes, fixes);
  point_at(sample.fix_z, fix_z);
  point_at(sample.motion, motion);
  point_at(sample.neighbours, neighbours);
}

void WireBlock::add(AgentId recipient, const runtime::Header& header,
                    const estimators::MeasurementBatch& batch) {
  owned.push_back(std::make_unique<WireBatch>(recipient, header, batch));
  batches.push_back(owned.back()->sample);  // shallow: points into the WireBatch, which stays put
}

const swarmloc_msg_MeasurementBlock& WireBlock::sample() {
  point_at(block.batches, batches);
  return block;
}

WireEstimate::WireEstimate(const runtime::EstimateReport& report)
    : rejected_by_reason(report.rejected_by_reason.begin(), report.rejected_by_reason.end()),
      field(report.estimate.field.begin(), report.estimate.field.end()) {
  links.reserve(report.links.size());
  for (const auto& link : report.links) {
    links.push_back(swarmloc_msg_LinkCounters{link.sender, link.arrived, link.delivered,
                                              link.dropped_injected, link.rejected, link.first_seq,
                                              link.last_seq, link.delivered_in_steps});
  }
  sample.agent_id = report.header.agent_id;
  sample.header = encode_header(report.header);
  put_vec2(report.estimate.mean_m, sample.mean_m);
  put_sym2(report.estimate.covariance, sample.covariance);
  sample.valid = report.estimate.valid;
  sample.inconsistent = report.estimate.inconsistent;
  sample.steps_run = report.steps_run;
  sample.samples_published = report.samples_published;
  sample.samples_published_in_steps = report.samples_published_in_steps;
  sample.cpu_s = report.cpu_s;
  sample.results_hash = report.results_hash;
  const auto& h = report.health;
  sample.health = swarmloc_msg_AgentHealth{h.ticks,
                                           h.late_ticks,
                                           h.missed_ticks,
                                           h.max_tick_lateness_s,
                                           h.mean_tick_lateness_s,
                                           h.batches_received,
                                           h.batches_merged,
                                           h.max_batch_wait_s,
                                           h.neighbour_age_mean_s,
                                           h.neighbour_age_max_s};
  point_at(sample.links, links);
  point_at(sample.rejected_by_reason, rejected_by_reason);
  point_at(sample.field, field);
  if (const auto& pose = report.estimate.heading) {
    heading = {pose->heading_rad, pose->variance_rad2, pose->position_cov_m_rad.x(),
               pose->position_cov_m_rad.y()};
  }
  point_at(sample.heading, heading);
  if (const auto& z = report.estimate.altitude) {
    altitude = {z->z_m, z->variance_m2, z->cross_m2.x(), z->cross_m2.y()};
  }
  point_at(sample.altitude, altitude);
}

WireControl::WireControl(const runtime::ControlMessage& message) {
  sample.agent_id = message.target;
  sample.header = encode_header(message.header);
  sample.command = static_cast<uint8_t>(message.command);
  sample.scenario_hash = message.scenario_hash;
  sample.start_world_ns = message.start_world_ns;
}

// ---------------------------------------------------------------------------------------------------
// Reads

runtime::Header decode_header(const swarmloc_msg_Header& wire) {
  runtime::Header header;
  header.agent_id = wire.agent_id;
  header.seq = wire.seq;
  header.step = wire.step;
  header.sender_stamp_ns = wire.sender_stamp_ns;
  header.world_stamp_ns = wire.world_stamp_ns;
  return header;
}

Inbound<estimators::StateMessage> decode(const swarmloc_msg_State& wire) {
  Inbound<estimators::StateMessage> inbound;
  inbound.header = decode_header(wire.header);
  inbound.message.mean_m = get_vec2(wire.mean_m);
  inbound.message.covariance = get_sym2(wire.covariance);
  inbound.message.degree = wire.degree;
  const bool flags_ok = codec::apply_state_flags(wire.flags, inbound.message);
  const auto edge_ranges = view(wire.edge_ranges);
  const auto altitude = view(wire.altitude);
  const auto edge_peer_z = view(wire.edge_peer_z);
  const auto cavities = view(wire.cavities);
  const auto cavity_offset_z = view(wire.cavity_offset_z);
  // A 3-D sender gives every edge's peer z and every cavity's offset z, a planar one none (its z is 0).
  inbound.well_formed = flags_ok && wire.agent_id == wire.header.agent_id && edge_ranges &&
                        edge_ranges->size() <= codec::kMaxEdgeRanges && altitude && altitude->size() <= 1 &&
                        edge_peer_z && edge_peer_z->size() == (altitude->empty() ? 0 : edge_ranges->size()) &&
                        cavities && cavities->size() <= codec::kMaxCavities && cavity_offset_z &&
                        cavity_offset_z->size() == (altitude->empty() ? 0 : cavities->size());
  if (!inbound.well_formed) return inbound;
  if (!altitude->empty()) {
    const auto& z = (*altitude)[0];
    inbound.message.altitude = Altitude{z.z_m, z.variance_m2, get_vec2(z.cross_m2)};
  }
  for (std::size_t k = 0; k < edge_ranges->size(); ++k) {
    const auto& edge = (*edge_ranges)[k];
    const Vec2 peer_mean = get_vec2(edge.peer_mean_m);
    const double peer_z = edge_peer_z->empty() ? 0.0 : (*edge_peer_z)[k];
    if (!std::isfinite(edge.information) || !(edge.information >= 0.0) || !std::isfinite(edge.mean_range_m) ||
        !peer_mean.allFinite() || !std::isfinite(peer_z)) {
      inbound.well_formed = false;
      return inbound;
    }
    inbound.message.edge_ranges.push_back(
        {edge.peer, edge.information, edge.mean_range_m, peer_mean, peer_z});
  }
  for (std::size_t k = 0; k < cavities->size(); ++k) {
    const auto& cavity = (*cavities)[k];
    const Vec2 offset = get_vec2(cavity.offset_m);
    const double offset_z = cavity_offset_z->empty() ? 0.0 : (*cavity_offset_z)[k];
    if (!offset.allFinite() || !std::isfinite(offset_z) || !std::isfinite(cavity.variance_m2) ||
        !(cavity.variance_m2 >= 0.0)) {
      inbound.well_formed = false;
      return inbound;
    }
    inbound.message.cavities.push_back({cavity.peer, offset, offset_z, cavity.variance_m2});
  }
  return inbound;
}

Inbound<estimators::InformationMessage> decode(const swarmloc_msg_Information& wire) {
  const auto header = decode_header(wire.header);
  const auto info_vec = view(wire.info_vec);
  const auto info_mat = view(wire.info_mat);
  if (!info_vec || !info_mat) {
    Inbound<estimators::InformationMessage> inbound;
    inbound.header = header;
    inbound.message.target = wire.target;
    inbound.message.world_step = wire.world_step;
    inbound.well_formed = false;
    return inbound;
  }
  auto inbound = codec::decode_information_fields(header, wire.agent_id, wire.target, *info_vec, *info_mat);
  inbound.message.world_step = wire.world_step;
  return inbound;
}

Inbound<estimators::ConsensusMessage> decode(const swarmloc_msg_Consensus& wire) {
  Inbound<estimators::ConsensusMessage> inbound;
  inbound.header = decode_header(wire.header);
  inbound.message.tau = wire.tau;
  inbound.message.round = wire.round;
  const auto values = view(wire.values);
  if (!values || values->size() > codec::kMaxConsensusValues || wire.agent_id != wire.header.agent_id) {
    inbound.well_formed = false;
    return inbound;
  }
  inbound.message.values.assign(values->begin(), values->end());
  return inbound;
}

Inbound<estimators::BeliefMessage> decode(const swarmloc_msg_Belief& wire) {
  Inbound<estimators::BeliefMessage> inbound;
  inbound.header = decode_header(wire.header);
  inbound.message.iteration = wire.iteration;
  inbound.message.mean_m = get_vec2(wire.mean_m);
  inbound.message.information = get_sym2(wire.information);
  inbound.message.infinite_information = wire.infinite_information;
  const auto contributions = view(wire.contributions);
  if (!contributions || contributions->size() > codec::kMaxBeliefContributions ||
      wire.agent_id != wire.header.agent_id) {
    inbound.well_formed = false;
    return inbound;
  }
  for (const auto& c : *contributions) {
    inbound.message.contributions.push_back(
        estimators::BeliefContribution{c.from, get_sym2(c.information), get_vec2(c.info_vec)});
  }
  return inbound;
}

codec::DecodedBatch decode(const swarmloc_msg_MeasurementBatch& wire) {
  codec::DecodedBatch decoded;
  decoded.recipient = wire.agent_id;
  decoded.header = decode_header(wire.header);
  decoded.batch.world_step = wire.header.step;
  decoded.batch.world_time_s = wire.world_time_s;
  const auto ranges = view(wire.ranges);
  const auto fixes = view(wire.fixes);
  const auto fix_z = view(wire.fix_z);
  const auto motion = view(wire.motion);
  const auto neighbours = view(wire.neighbours);
  const auto bearings = view(wire.bearings);
  const auto relative = view(wire.relative);
  const auto targets = view(wire.targets);
  const auto paths = view(wire.paths);
  const auto odometry = view(wire.odometry);
  const auto range_bearings = view(wire.range_bearings);
  if (!ranges || !fixes || !motion || !neighbours || !bearings || !relative || !targets || !paths ||
      !odometry || !range_bearings || !fix_z || fixes->size() > 1 || fix_z->size() > fixes->size() ||
      motion->size() > 1 || (!wire.has_odometry && !odometry->empty())) {
    decoded.well_formed = false;
    return decoded;
  }
  for (const auto& m : *bearings) {
    decoded.batch.bearings.push_back(estimators::BearingMeasurement{m.peer, m.bearing_rad, m.std_rad});
  }
  for (const auto& m : *relative) {
    decoded.batch.relative.push_back(
        estimators::RelativeMeasurement{m.peer, get_vec2(m.delta_m), get_sym2(m.covariance)});
  }
  for (const auto& m : *targets) {
    decoded.batch.targets.push_back(
        estimators::TargetObservation{m.target, get_vec2(m.value), get_sym2(m.covariance), m.kind});
  }
  for (const auto& m : *paths) {
    decoded.batch.paths.push_back(
        estimators::MultipathMeasurement{m.peer, m.path_index, m.length_m, m.aoa_here_rad, m.aoa_there_rad});
  }
  decoded.batch.ranges.reserve(ranges->size());
  for (const auto& range : *ranges) {
    decoded.batch.ranges.push_back(estimators::RangeMeasurement{range.peer, range.range_m, range.std_m});
  }
  if (!fixes->empty()) {
    estimators::AbsoluteFix fix;
    fix.position_m = get_vec2((*fixes)[0].position_m);
    fix.covariance = get_sym2((*fixes)[0].covariance);
    if (!fix_z->empty()) fix.z_m = (*fix_z)[0];
    decoded.batch.fix = fix;
  }
  if (!motion->empty()) {
    estimators::MotionInput input;
    input.velocity_mps = get_vec2((*motion)[0].velocity_mps);
    input.dt_s = (*motion)[0].dt_s;
    input.process_cov = get_sym2((*motion)[0].process_cov);
    decoded.batch.motion = input;
  }
  if (wire.has_odometry) {
    estimators::OdometryInput input;
    input.v_std = wire.odometry_v_std;
    input.omega_std = wire.odometry_omega_std;
    for (const auto& segment : *odometry) {
      input.segments.push_back(estimators::OdometrySegment{segment.v_mps, segment.omega_radps, segment.dt_s});
    }
    decoded.batch.odometry = std::move(input);
  }
  for (const auto& m : *range_bearings) decoded.batch.range_bearings.push_back(range_bearing_of(m));
  decoded.batch.neighbours.assign(neighbours->begin(), neighbours->end());
  return decoded;
}

codec::DecodedEstimate decode(const swarmloc_msg_Estimate& wire) {
  codec::DecodedEstimate decoded;
  auto& report = decoded.report;
  report.header = decode_header(wire.header);
  report.estimate.mean_m = get_vec2(wire.mean_m);
  report.estimate.covariance = get_sym2(wire.covariance);
  report.estimate.valid = wire.valid;
  report.estimate.inconsistent = wire.inconsistent;
  report.steps_run = wire.steps_run;
  report.samples_published = wire.samples_published;
  report.samples_published_in_steps = wire.samples_published_in_steps;
  report.cpu_s = wire.cpu_s;
  report.results_hash = wire.results_hash;
  const auto& h = wire.health;
  report.health = runtime::AgentHealth{h.ticks,
                                       h.late_ticks,
                                       h.missed_ticks,
                                       h.max_tick_lateness_s,
                                       h.mean_tick_lateness_s,
                                       h.batches_received,
                                       h.batches_merged,
                                       h.max_batch_wait_s,
                                       h.neighbour_age_mean_s,
                                       h.neighbour_age_max_s};
  const auto links = view(wire.links);
  const auto reasons = view(wire.rejected_by_reason);
  const auto field = view(wire.field);
  const auto heading = view(wire.heading);
  // A sender may know fewer reasons (older build: the rest stay 0), never more than this build.
  // Health figures are durations and counts: anything else is a broken or hostile sender.
  const auto duration = [](double s) { return std::isfinite(s) && s >= 0.0 && s < 1e9; };
  const bool health_ok = duration(h.max_tick_lateness_s) && duration(h.mean_tick_lateness_s) &&
                         duration(h.max_batch_wait_s) && duration(h.neighbour_age_mean_s) &&
                         duration(h.neighbour_age_max_s) && h.late_ticks <= h.ticks &&
                         h.batches_merged <= h.batches_received;
  const bool heading_ok =
      heading &&
      (heading->empty() || (heading->size() == 4 && std::all_of(heading->begin(), heading->end(),
                                                                [](double v) { return std::isfinite(v); })));
  const auto altitude = view(wire.altitude);
  const bool altitude_ok =
      altitude && (altitude->empty() || (altitude->size() == 4 && [&] {
                     const Altitude z{(*altitude)[0], (*altitude)[1], Vec2((*altitude)[2], (*altitude)[3])};
                     return codec::plausible_altitude(report.estimate.covariance, z);
                   }()));
  if (!links || !reasons || !field || !heading_ok || !altitude_ok ||
      reasons->size() > runtime::kRejectReasonCount || field->size() > codec::kMaxFieldValues ||
      wire.agent_id != wire.header.agent_id || !health_ok) {
    decoded.well_formed = false;
    return decoded;
  }
  report.estimate.field = Eigen::Map<const VecX>(field->data(), static_cast<Eigen::Index>(field->size()));
  if (!heading->empty()) {
    report.estimate.heading =
        estimators::HeadingEstimate{(*heading)[0], (*heading)[1], Vec2((*heading)[2], (*heading)[3])};
  }
  if (!altitude->empty()) {
    report.estimate.altitude = Altitude{(*altitude)[0], (*altitude)[1], Vec2((*altitude)[2], (*altitude)[3])};
  }
  report.links.reserve(links->size());
  for (const auto& link : *links) {
    report.links.push_back(runtime::LinkCounters{link.sender, link.arrived, link.delivered,
                                                 link.dropped_injected, link.rejected, link.first_seq,
                                                 link.last_seq, link.delivered_in_steps});
  }
  std::copy(reasons->begin(), reasons->end(), report.rejected_by_reason.begin());
  return decoded;
}

codec::DecodedControl decode(const swarmloc_msg_Control& wire) {
  codec::DecodedControl decoded;
  decoded.message.header = decode_header(wire.header);
  decoded.message.target = wire.agent_id;
  decoded.message.scenario_hash = wire.scenario_hash;
  decoded.message.start_world_ns = wire.start_world_ns;
  const auto command = codec::control_command(wire.command);
  if (!command) {
    decoded.well_formed = false;
    return decoded;
  }
  decoded.message.command = *command;
  return decoded;
}

}  // namespace swarmloc::dds
