// The .slrec framing (slrec_codec.hpp).
#include "swarmloc/runtime/slrec_codec.hpp"

#include <zlib.h>

#include <system_error>

namespace swarmloc::runtime::slrec {

/// zlib's CRC-32 (the IEEE polynomial; it detects every error burst of up to 32 bits).
std::uint32_t crc32_of(const void* data, std::size_t size) {
  return static_cast<std::uint32_t>(
      crc32_z(crc32_z(0L, Z_NULL, 0), static_cast<const Bytef*>(data), static_cast<z_size_t>(size)));
}

std::string tag_name(std::uint8_t tag) {
  switch (tag) {
    case kTagHead:
      return "header record";
    case kTagStep:
      return "step record";
    case kTagSample:
      return "sample record";
    case kTagEnd:
      return "end marker";
    default:
      return "record of unknown tag " + std::to_string(tag);
  }
}

/// Magic, kind, version and (version 4) the CRC-32 of those 8 bytes.
std::string file_header(std::uint8_t kind) {
  Encoder out;
  for (char c : kMagic) out.u8(static_cast<std::uint8_t>(c));
  out.u8(kind);
  out.u16(kRecordingVersion);
  out.u32(crc32_of(out.bytes().data(), out.bytes().size()));
  return out.bytes();
}

/// One version 4 record: u8 tag, u32 payload length, u32 CRC-32 of those 5 bytes, the payload, u32 CRC-32
/// of the payload. The header's own checksum lets a reader tell a record cut by a kill (a shorter file)
/// from a damaged length.
void write_record(OutputFile& out, std::uint8_t tag, const std::string& payload) {
  if (payload.size() > std::numeric_limits<std::uint32_t>::max()) {
    throw std::length_error("recording: a " + tag_name(tag) + " of " + std::to_string(payload.size()) +
                            " bytes exceeds 4 GiB");
  }
  Encoder head;
  head.u8(tag);
  head.u32(static_cast<std::uint32_t>(payload.size()));
  head.u32(crc32_of(head.bytes().data(), head.bytes().size()));
  Encoder trailer;
  trailer.u32(crc32_of(payload.data(), payload.size()));
  out.write(head.bytes());
  out.write(payload);
  out.write(trailer.bytes());
}

void encode(Encoder& out, const estimators::StateMessage& m) {
  out.vec2(m.mean_m), out.mat2(m.covariance), out.boolean(m.anchor), out.boolean(m.active), out.u16(m.degree);
  out.count(m.edge_ranges.size());        // version 5
  for (const auto& edge : m.edge_ranges)  // version 6: and the peer's mean
    out.i32(edge.peer), out.f64(edge.information), out.f64(edge.mean_range_m), out.vec2(edge.peer_mean_m);
  out.boolean(m.inconsistent);   // version 8
  out.count(m.cavities.size());  // version 9
  for (const auto& cavity : m.cavities)
    out.i32(cavity.peer), out.vec2(cavity.offset_m), out.f64(cavity.offset_z_m), out.f64(cavity.variance_m2);
}
void encode(Encoder& out, const estimators::InformationMessage& m) {
  out.i32(m.target);
  out.count(static_cast<std::size_t>(m.info_vec.size()));
  for (Eigen::Index k = 0; k < m.info_vec.size(); ++k) out.f64(m.info_vec(k));
  out.count(static_cast<std::size_t>(m.info_mat.rows()));
  out.count(static_cast<std::size_t>(m.info_mat.cols()));
  for (Eigen::Index r = 0; r < m.info_mat.rows(); ++r)
    for (Eigen::Index c = 0; c < m.info_mat.cols(); ++c) out.f64(m.info_mat(r, c));
  out.i64(m.world_step);
}
void encode(Encoder& out, const estimators::ConsensusMessage& m) {
  out.i64(m.tau), out.i32(m.round);
  out.count(m.values.size());
  for (double v : m.values) out.f64(v);
}
void encode(Encoder& out, const estimators::BeliefMessage& m) {
  out.i64(m.iteration), out.vec2(m.mean_m), out.mat2(m.information), out.boolean(m.infinite_information);
  out.count(m.contributions.size());
  for (const auto& c : m.contributions) out.i32(c.from), out.mat2(c.information), out.vec2(c.info_vec);
}

void encode(Encoder& out, const estimators::ObservationMessage& m) {
  out.i64(m.origin_step);
  for (Eigen::Index k = 0; k < 3; ++k) out.f64(m.origin_pose(k));
  for (Eigen::Index r = 0; r < 3; ++r)
    for (Eigen::Index c = 0; c < 3; ++c) out.f64(m.origin_covariance(r, c));
  out.count(m.spans.size());
  for (const auto& span : m.spans) {
    out.i64(span.first_world_step), out.i64(span.world_step), out.f64(span.world_time_s);
    out.boolean(span.odometry.has_value());
    if (span.odometry) {
      out.f64(span.odometry->v_std), out.f64(span.odometry->omega_std);
      out.count(span.odometry->segments.size());
      for (const auto& s : span.odometry->segments) out.f64(s.v_mps), out.f64(s.omega_radps), out.f64(s.dt_s);
    }
    out.count(span.range_bearings.size());
    for (const auto& rb : span.range_bearings) {
      out.i32(rb.peer), out.boolean(rb.landmark), out.vec2(rb.landmark_m), out.mat2(rb.landmark_cov);
      out.f64(rb.range_m), out.f64(rb.bearing_rad), out.f64(rb.range_std_m), out.f64(rb.bearing_std_rad);
      out.f64(rb.age_s);
    }
  }
}

/// `path` after creating its parent directories (OutputError naming the directory if that fails).
const std::filesystem::path& with_parent_directories(const std::filesystem::path& path) {
  if (path.has_parent_path()) {
    std::error_code error;
    std::filesystem::create_directories(path.parent_path(), error);
    if (error) throw OutputError(path.parent_path(), "create the directory", error.value());
  }
  return path;
}

}  // namespace swarmloc::runtime::slrec
