#pragma once
// Helpers of the IDL <-> swarmloc conversion shared by convert.cpp and convert_observations.cpp.
#include <algorithm>
#include <optional>
#include <span>
#include <type_traits>
#include <vector>

#include "swarmloc.h"
#include "wire_codec.hpp"

namespace swarmloc::dds::wire {

inline swarmloc_msg_Header encode_header(const runtime::Header& header) {
  swarmloc_msg_Header wire{};
  wire.agent_id = header.agent_id;
  wire.seq = header.seq;
  wire.step = header.step;
  wire.sender_stamp_ns = header.sender_stamp_ns;
  wire.world_stamp_ns = header.world_stamp_ns;
  return wire;
}

inline void put_vec2(const Vec2& value, double (&out)[2]) {
  out[0] = value.x();
  out[1] = value.y();
}

inline Vec2 get_vec2(const double (&in)[2]) { return Vec2(in[0], in[1]); }

inline void put_sym2(const Mat2& value, double (&out)[3]) {
  const auto packed = codec::pack_sym2(value);
  std::copy(packed.begin(), packed.end(), out);
}

inline Mat2 get_sym2(const double (&in)[3]) { return codec::unpack_sym2(std::span<const double, 3>(in)); }

inline swarmloc_msg_RangeBearing wire_range_bearing(const estimators::RangeBearingMeasurement& m) {
  swarmloc_msg_RangeBearing wire{};
  wire.peer = m.peer;
  wire.landmark = m.landmark;
  put_vec2(m.landmark_m, wire.landmark_m);
  put_sym2(m.landmark_cov, wire.landmark_cov);
  wire.range_m = m.range_m;
  wire.bearing_rad = m.bearing_rad;
  wire.range_std_m = m.range_std_m;
  wire.bearing_std_rad = m.bearing_std_rad;
  wire.age_s = m.age_s;
  return wire;
}

inline estimators::RangeBearingMeasurement range_bearing_of(const swarmloc_msg_RangeBearing& m) {
  estimators::RangeBearingMeasurement measurement;
  measurement.peer = m.peer;
  measurement.landmark = m.landmark;
  measurement.landmark_m = get_vec2(m.landmark_m);
  measurement.landmark_cov = get_sym2(m.landmark_cov);
  measurement.range_m = m.range_m;
  measurement.bearing_rad = m.bearing_rad;
  measurement.range_std_m = m.range_std_m;
  measurement.bearing_std_rad = m.bearing_std_rad;
  measurement.age_s = m.age_s;
  return measurement;
}

/// Points an IDL sequence at a vector's storage for a write (Cyclone does not free it: _release=false).
template <typename Sequence, typename Element>
void point_at(Sequence& sequence, std::vector<Element>& storage) {
  sequence._maximum = static_cast<uint32_t>(storage.size());
  sequence._length = static_cast<uint32_t>(storage.size());
  sequence._buffer = storage.empty() ? nullptr : storage.data();
  sequence._release = false;
}

/// A received sequence as a span; nullopt if it claims elements but has no buffer.
template <typename Sequence>
auto view(const Sequence& sequence)
    -> std::optional<std::span<const std::remove_pointer_t<decltype(sequence._buffer)>>> {
  using Element = std::remove_pointer_t<decltype(sequence._buffer)>;
  if (sequence._length == 0) {
    return std::span<const Element>();
  }
  if (sequence._buffer == nullptr) {
    return std::nullopt;
  }
  return std::span<const Element>(sequence._buffer, sequence._length);
}

}  // namespace swarmloc::dds::wire
