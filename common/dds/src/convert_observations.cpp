// OBSERVATIONS samples (team_pose_ekf) <-> swarmloc (convert.hpp).
#include <string>

#include "convert.hpp"
#include "convert_support.hpp"

namespace swarmloc::dds {

using wire::encode_header;
using wire::get_sym2;
using wire::point_at;
using wire::range_bearing_of;
using wire::view;
using wire::wire_range_bearing;

WireObservations::WireObservations(const runtime::Header& header,
                                   const estimators::ObservationMessage& message) {
  sample.agent_id = header.agent_id;
  sample.header = encode_header(header);
  sample.origin_step = message.origin_step;
  for (int k = 0; k < 3; ++k) sample.origin_pose[k] = message.origin_pose(k);
  for (int r = 0, at = 0; r < 3; ++r)
    for (int c = r; c < 3; ++c) sample.origin_covariance[at++] = message.origin_covariance(r, c);
  if (message.spans.size() > codec::kMaxObservedSpans) {
    throw DdsError("publish_observations: " + std::to_string(message.spans.size()) + " spans (IDL bound 64)");
  }
  odometry.resize(message.spans.size());
  range_bearings.resize(message.spans.size());
  for (std::size_t k = 0; k < message.spans.size(); ++k) {
    const estimators::ObservedSteps& span = message.spans[k];
    swarmloc_msg_ObservedSpan wire{};
    wire.first_world_step = span.first_world_step;
    wire.world_step = span.world_step;
    wire.world_time_s = span.world_time_s;
    if (span.odometry) {
      wire.has_odometry = true;
      wire.odometry_v_std = span.odometry->v_std;
      wire.odometry_omega_std = span.odometry->omega_std;
      for (const auto& s : span.odometry->segments) {
        odometry[k].push_back(swarmloc_msg_OdometrySegment{s.v_mps, s.omega_radps, s.dt_s});
      }
    }
    for (const auto& m : span.range_bearings) range_bearings[k].push_back(wire_range_bearing(m));
    if (odometry[k].size() > codec::kMaxSpanOdometry ||
        range_bearings[k].size() > codec::kMaxSpanRangeBearings) {
      throw DdsError(
          "publish_observations: a span over the IDL bounds (1024 odometry segments, 256 sightings)");
    }
    point_at(wire.odometry, odometry[k]);
    point_at(wire.range_bearings, range_bearings[k]);
    spans.push_back(wire);
  }
  point_at(sample.spans, spans);
}

namespace {

/// One span of a received Observations sample; false if a sequence is broken or over its bound.
bool decode_span(const swarmloc_msg_ObservedSpan& wire, estimators::ObservedSteps& span) {
  const auto odometry = view(wire.odometry);
  const auto range_bearings = view(wire.range_bearings);
  if (!odometry || !range_bearings || odometry->size() > codec::kMaxSpanOdometry ||
      range_bearings->size() > codec::kMaxSpanRangeBearings || (!wire.has_odometry && !odometry->empty())) {
    return false;
  }
  span.first_world_step = wire.first_world_step;
  span.world_step = wire.world_step;
  span.world_time_s = wire.world_time_s;
  if (wire.has_odometry) {
    estimators::OdometryInput input;
    input.v_std = wire.odometry_v_std;
    input.omega_std = wire.odometry_omega_std;
    for (const auto& s : *odometry)
      input.segments.push_back(estimators::OdometrySegment{s.v_mps, s.omega_radps, s.dt_s});
    span.odometry = std::move(input);
  }
  for (const auto& m : *range_bearings) span.range_bearings.push_back(range_bearing_of(m));
  return true;
}

}  // namespace

Inbound<estimators::ObservationMessage> decode(const swarmloc_msg_Observations& wire) {
  Inbound<estimators::ObservationMessage> inbound;
  inbound.header = decode_header(wire.header);
  auto& message = inbound.message;
  message.origin_step = wire.origin_step;
  for (int k = 0; k < 3; ++k) message.origin_pose(k) = wire.origin_pose[k];
  for (int r = 0, at = 0; r < 3; ++r) {
    for (int c = r; c < 3; ++c, ++at) {
      message.origin_covariance(r, c) = wire.origin_covariance[at];
      message.origin_covariance(c, r) = wire.origin_covariance[at];
    }
  }
  const auto spans = view(wire.spans);
  if (!spans || spans->size() > codec::kMaxObservedSpans || wire.agent_id != wire.header.agent_id) {
    inbound.well_formed = false;
    return inbound;
  }
  message.spans.resize(spans->size());
  for (std::size_t k = 0; k < spans->size(); ++k) {
    if (!decode_span((*spans)[k], message.spans[k])) {
      inbound.well_formed = false;
      message.spans.clear();
      return inbound;
    }
  }
  return inbound;
}

namespace codec {

Inbound<estimators::ObservationMessage> round_trip(const runtime::Header& header,
                                                   const estimators::ObservationMessage& message) {
  const WireObservations wire(header, message);
  return decode(wire.sample);
}

}  // namespace codec

}  // namespace swarmloc::dds
