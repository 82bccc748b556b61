#pragma once
// Reading .slrec files (recording.hpp): the bounds-checked decoder shared by the recording reader
// (recording.cpp) and the sample-log reader (sample_log_reader.cpp). Private to rundir.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "swarmloc/rundir/recording.hpp"
#include "swarmloc/runtime/slrec_codec.hpp"

namespace swarmloc::rundir::slrec {
// The framing the agents write (runtime/slrec_codec.hpp) is what this decoder reads.
using namespace runtime::slrec;  // NOLINT(google-build-using-namespace)

inline constexpr int kMaxAgents = 1'000'000;
inline constexpr std::uint32_t kMaxScenarioBytes = 16u << 20;
inline constexpr std::uint32_t kMaxMatrixSide = 4096;

// ---- Decoding: every read checked against the bytes left ----

class Decoder {
 public:
  Decoder(const std::vector<std::uint8_t>& bytes, std::string source)
      : bytes_(bytes), source_(std::move(source)), limit_(bytes.size()) {}

  /// A version 4 record whose checksums matched: its payload is bytes [payload_at, payload_end).
  struct Record {
    std::uint8_t tag = 0;
    std::size_t at = 0;  ///< where its header starts
    std::size_t payload_at = 0;
    std::size_t payload_end = 0;
  };

  [[noreturn]] void fail(const std::string& what, std::size_t at) const {
    throw RecordingError(source_ + ": byte " + std::to_string(at) + ": " + what);
  }
  [[noreturn]] void fail(const std::string& what) const { fail(what, offset_); }
  /// The file ends (or a count claims more than the bytes left) inside a record. Inside a checksummed
  /// payload the bytes are all there, so running short is damage, not a cut file.
  [[noreturn]] void fail_short(const std::string& what, std::size_t at) {
    ran_out_ = limit_ == bytes_.size();
    fail(what, at);
  }
  [[nodiscard]] bool ran_out() const { return ran_out_; }

  [[nodiscard]] std::size_t offset() const { return offset_; }
  void seek(std::size_t offset) { offset_ = offset; }
  /// Bytes left in the current record's payload (version 4) or in the file.
  [[nodiscard]] std::size_t left() const { return limit_ - offset_; }
  [[nodiscard]] bool at_end() const { return offset_ == bytes_.size(); }
  [[nodiscard]] std::size_t bytes_left_in_file() const { return bytes_.size() - offset_; }

  /// Version 4: the record at the offset, both checksums verified before any field is read. The reads
  /// that follow are confined to its payload until end_record().
  Record begin_record() {
    Record r;
    r.at = offset_;
    if (left() < kRecordHeaderBytes) {
      fail_short("truncated: a record header needs " + std::to_string(kRecordHeaderBytes) + " bytes, " +
                     std::to_string(left()) + " left",
                 r.at);
    }
    const std::uint32_t head_crc = crc32_of(bytes_.data() + offset_, 5);
    r.tag = u8();
    const std::uint32_t length = u32();
    if (u32() != head_crc)
      fail("checksum mismatch in a record header (tag and length): the file is damaged", r.at);
    r.payload_at = offset_;
    r.payload_end = offset_ + length;
    if (length > left() || left() - length < kRecordTrailerBytes) {
      fail_short("truncated: the " + tag_name(r.tag) + " of " + std::to_string(length) + " bytes needs " +
                     std::to_string(std::size_t{length} + kRecordTrailerBytes) + " bytes, " +
                     std::to_string(left()) + " left",
                 r.at);
    }
    offset_ = r.payload_end;
    const std::uint32_t stored = u32();
    if (crc32_of(bytes_.data() + r.payload_at, length) != stored) {
      fail("checksum mismatch in the " + tag_name(r.tag) + " (bytes " + std::to_string(r.at) + " to " +
               std::to_string(offset_) + "): the file is damaged",
           r.at);
    }
    offset_ = r.payload_at;
    limit_ = r.payload_end;
    return r;
  }
  /// Every byte of the payload must have been read; moves past the record's checksum.
  void end_record(const Record& r) {
    if (offset_ != r.payload_end) {
      fail(std::to_string(r.payload_end - offset_) + " unread bytes at the end of the " + tag_name(r.tag));
    }
    limit_ = bytes_.size();
    offset_ = r.payload_end + kRecordTrailerBytes;
  }

  std::uint8_t u8() { return static_cast<std::uint8_t>(le(1)); }
  bool boolean() {
    const auto at = offset_;
    const auto v = u8();
    if (v > 1) fail("flag " + std::to_string(v) + " is neither 0 nor 1", at);
    return v == 1;
  }
  std::uint16_t u16() { return static_cast<std::uint16_t>(le(2)); }
  std::uint32_t u32() { return static_cast<std::uint32_t>(le(4)); }
  std::int32_t i32() { return static_cast<std::int32_t>(u32()); }
  std::uint64_t u64() { return le(8); }
  std::int64_t i64() { return static_cast<std::int64_t>(le(8)); }
  double f64() { return std::bit_cast<double>(le(8)); }
  Vec2 vec2() {
    const double x = f64();
    return Vec2(x, f64());
  }
  Mat2 mat2() {
    Mat2 m;
    m(0, 0) = f64(), m(0, 1) = f64(), m(1, 0) = f64(), m(1, 1) = f64();
    return m;
  }
  /// A count of elements of at least `element_bytes` each: more than the bytes left can hold is an
  /// error before anything is allocated.
  std::size_t count(std::size_t element_bytes, const char* what) {
    const auto at = offset_;
    const std::size_t n = u32();
    if (element_bytes > 0 && n > left() / element_bytes) {
      fail_short(std::string(what) + ": count " + std::to_string(n) + " exceeds the " +
                     std::to_string(left()) + " bytes left",
                 at);
    }
    return n;
  }
  AgentId agent(int agents, const char* what) {
    const auto at = offset_;
    const AgentId id = i32();
    if (id < 0 || id >= agents)
      fail(std::string(what) + " " + std::to_string(id) + " outside [0, " + std::to_string(agents) + ")", at);
    return id;
  }
  std::string text(std::uint32_t max_bytes, const char* what) {
    const std::size_t n = count(1, what);
    if (n > max_bytes)
      fail(std::string(what) + ": " + std::to_string(n) + " bytes (at most " + std::to_string(max_bytes) +
           ")");
    std::string s(reinterpret_cast<const char*>(bytes_.data() + offset_), n);
    offset_ += n;
    return s;
  }

  /// Magic, kind, version and (version 4) the header's checksum. Returns the version.
  std::uint16_t file_header(std::uint8_t kind) {
    if (bytes_.size() < sizeof kMagic || std::memcmp(bytes_.data(), kMagic, sizeof kMagic) != 0)
      fail("not a swarmloc recording (bad magic; expected \"SLREC\")", 0);
    offset_ = sizeof kMagic;
    const auto at = offset_;
    const std::uint8_t found = u8();
    const auto version_at = offset_;
    const std::uint16_t version = u16();
    if (version >= runtime::kFirstChecksummedRecordingVersion && version <= runtime::kRecordingVersion) {
      // Checked first: a damaged kind or version byte is damage, not another kind of file.
      if (u32() != crc32_of(bytes_.data(), kFileHeaderBytes))
        fail("checksum mismatch in the file header: the file is damaged", 0);
    }
    if (found != kind) {
      auto name = [](std::uint8_t k) -> std::string {
        if (k == kKindRecording) return "a world recording (recording.slrec)";
        if (k == kKindSampleLog) return "a sample log (recording/*.slrec)";
        return "of unknown kind " + std::to_string(k);
      };
      fail("the file is " + name(found) + ", expected " + name(kind), at);
    }
    if (version < runtime::kOldestReadableRecordingVersion || version > runtime::kRecordingVersion) {
      fail("format version " + std::to_string(version) + " is not supported (this build reads versions " +
               std::to_string(runtime::kOldestReadableRecordingVersion) + " to " +
               std::to_string(runtime::kRecordingVersion) + ")",
           version_at);
    }
    return version;
  }

 private:
  std::uint64_t le(int width) {
    if (left() < static_cast<std::size_t>(width)) {
      fail_short(
          "truncated: needs " + std::to_string(width) + " more bytes, " + std::to_string(left()) + " left",
          offset_);
    }
    std::uint64_t v = 0;
    for (int k = 0; k < width; ++k)
      v |= static_cast<std::uint64_t>(bytes_[offset_ + static_cast<std::size_t>(k)]) << (8 * k);
    offset_ += static_cast<std::size_t>(width);
    return v;
  }

  const std::vector<std::uint8_t>& bytes_;
  std::string source_;
  std::size_t limit_;  ///< the end of the current version 4 payload, else of the file
  std::size_t offset_ = 0;
  bool ran_out_ = false;
};

/// The whole file; RecordingError (naming the path and the OS error) for anything but a readable file.
inline std::vector<std::uint8_t> read_file(const std::filesystem::path& path) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) {
    const auto inside = path / (path.filename() == kSampleLogDirectory ? "agent_<id>.slrec" : kRecordingFile);
    throw RecordingError(path.string() + ": is a directory; pass " + inside.string());
  }
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (file == nullptr) throw RecordingError(path.string() + ": cannot be read: " + std::strerror(errno));
  std::vector<std::uint8_t> bytes;
  std::uint8_t chunk[1 << 16];
  std::size_t got = 0;
  while ((got = std::fread(chunk, 1, sizeof chunk, file)) > 0) bytes.insert(bytes.end(), chunk, chunk + got);
  const bool failed = std::ferror(file) != 0;
  const int read_error = errno;
  std::fclose(file);
  if (failed) throw RecordingError(path.string() + ": read error: " + std::strerror(read_error));
  return bytes;
}

template <typename Message>
void decode_into(Decoder& in, Message& m);
template <>
inline void decode_into(Decoder& in, estimators::StateMessage& m) {
  m.mean_m = in.vec2(), m.covariance = in.mat2();
  m.anchor = in.boolean(), m.active = in.boolean();
  m.degree = in.u16();
}
template <>
inline void decode_into(Decoder& in, estimators::InformationMessage& m) {
  m.target = in.i32();
  const auto n = in.count(8, "information vector");
  m.info_vec.resize(static_cast<Eigen::Index>(n));
  for (std::size_t k = 0; k < n; ++k) m.info_vec(static_cast<Eigen::Index>(k)) = in.f64();
  const auto at = in.offset();
  const auto rows = in.u32();
  const auto cols = in.u32();
  if (rows > kMaxMatrixSide || cols > kMaxMatrixSide ||
      static_cast<std::uint64_t>(rows) * cols > in.left() / 8) {
    in.fail_short("information matrix " + std::to_string(rows) + " x " + std::to_string(cols) +
                      " exceeds the bytes left",
                  at);
  }
  m.info_mat.resize(rows, cols);
  for (Eigen::Index r = 0; r < m.info_mat.rows(); ++r)
    for (Eigen::Index c = 0; c < m.info_mat.cols(); ++c) m.info_mat(r, c) = in.f64();
}
template <>
inline void decode_into(Decoder& in, estimators::ConsensusMessage& m) {
  m.tau = in.i64(), m.round = in.i32();
  m.values.resize(in.count(8, "consensus values"));
  for (auto& v : m.values) v = in.f64();
}
template <>
inline void decode_into(Decoder& in, estimators::BeliefMessage& m) {
  m.iteration = in.i64(), m.mean_m = in.vec2(), m.information = in.mat2();
  m.infinite_information = in.boolean();
}
template <>
inline void decode_into(Decoder& in, estimators::ObservationMessage& m) {
  m.origin_step = in.i64();
  for (Eigen::Index k = 0; k < 3; ++k) m.origin_pose(k) = in.f64();
  for (Eigen::Index r = 0; r < 3; ++r)
    for (Eigen::Index c = 0; c < 3; ++c) m.origin_covariance(r, c) = in.f64();
  m.spans.resize(in.count(3 * 8 + 1 + 4, "observed spans"));
  for (auto& span : m.spans) {
    span.first_world_step = in.i64(), span.world_step = in.i64(), span.world_time_s = in.f64();
    if (in.boolean()) {
      auto& odometry = span.odometry.emplace();
      odometry.v_std = in.f64(), odometry.omega_std = in.f64();
      odometry.segments.resize(in.count(3 * 8, "odometry segments"));
      for (auto& segment : odometry.segments)
        segment.v_mps = in.f64(), segment.omega_radps = in.f64(), segment.dt_s = in.f64();
    }
    span.range_bearings.resize(in.count(4 + 1 + 11 * 8, "range-bearings"));
    for (auto& rb : span.range_bearings) {
      rb.peer = in.i32(), rb.landmark = in.boolean(), rb.landmark_m = in.vec2(), rb.landmark_cov = in.mat2();
      rb.range_m = in.f64(), rb.bearing_rad = in.f64(), rb.range_std_m = in.f64(),
      rb.bearing_std_rad = in.f64(), rb.age_s = in.f64();
    }
  }
}

}  // namespace swarmloc::rundir::slrec
