// Binary recordings and sample logs (recording.hpp; the format is described in docs/record-replay.md).
#include "swarmloc/rundir/recording.hpp"

#include <zlib.h>

#include <bit>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <limits>
#include <system_error>

namespace swarmloc::sim {
namespace {

constexpr char kMagic[5] = {'S', 'L', 'R', 'E', 'C'};
constexpr std::uint8_t kKindRecording = 'W';
constexpr std::uint8_t kKindSampleLog = 'S';
constexpr std::uint8_t kTagHead = 'H';  // version 4: the world at step 0, or a sample log's agent count
constexpr std::uint8_t kTagStep = 'T';
constexpr std::uint8_t kTagSample = 'R';
constexpr std::uint8_t kTagEnd = 'E';
/// Version 4 framing: the file header's CRC; a record's tag, length and their CRC; the payload's CRC.
constexpr std::size_t kFileHeaderBytes = 8;
constexpr std::size_t kRecordHeaderBytes = 1 + 4 + 4;
constexpr std::size_t kRecordTrailerBytes = 4;

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

constexpr int kMaxAgents = 1'000'000;
constexpr std::uint32_t kMaxScenarioBytes = 16u << 20;
constexpr std::uint32_t kMaxMatrixSide = 4096;

// ---- Encoding: little-endian, doubles as their IEEE-754 bits ----

class Encoder {
 public:
  void u8(std::uint8_t v) { bytes_.push_back(static_cast<char>(v)); }
  void boolean(bool v) { u8(v ? 1 : 0); }
  void u16(std::uint16_t v) { le(v, 2); }
  void u32(std::uint32_t v) { le(v, 4); }
  void i32(std::int32_t v) { le(static_cast<std::uint32_t>(v), 4); }
  void u64(std::uint64_t v) { le(v, 8); }
  void i64(std::int64_t v) { le(static_cast<std::uint64_t>(v), 8); }
  void f64(double v) { le(std::bit_cast<std::uint64_t>(v), 8); }
  void vec2(const Vec2& v) { f64(v.x()), f64(v.y()); }
  /// All four entries (row-major), so a non-symmetric matrix survives too.
  void mat2(const Mat2& m) { f64(m(0, 0)), f64(m(0, 1)), f64(m(1, 0)), f64(m(1, 1)); }
  void count(std::size_t n) {
    if (n > std::numeric_limits<std::uint32_t>::max()) throw std::length_error("recording: count too large");
    u32(static_cast<std::uint32_t>(n));
  }
  void text(const std::string& s) {
    count(s.size());
    bytes_.append(s);
  }
  [[nodiscard]] const std::string& bytes() const { return bytes_; }
  void clear() { bytes_.clear(); }

 private:
  void le(std::uint64_t v, int width) {
    for (int k = 0; k < width; ++k) bytes_.push_back(static_cast<char>((v >> (8 * k)) & 0xFF));
  }
  std::string bytes_;
};

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

void encode(Encoder& out, const estimators::MeasurementBatch& b) {
  out.i64(b.world_step);
  out.f64(b.world_time_s);
  out.count(b.ranges.size());
  for (const auto& m : b.ranges) out.i32(m.peer), out.f64(m.range_m), out.f64(m.std_m);
  out.count(b.bearings.size());
  for (const auto& m : b.bearings) out.i32(m.peer), out.f64(m.bearing_rad), out.f64(m.std_rad);
  out.count(b.relative.size());
  for (const auto& m : b.relative) out.i32(m.peer), out.vec2(m.delta_m), out.mat2(m.covariance);
  out.count(b.paths.size());
  for (const auto& m : b.paths) {
    out.i32(m.peer), out.i32(m.path_index), out.f64(m.length_m), out.f64(m.aoa_here_rad);
    out.f64(m.aoa_there_rad);
  }
  out.count(b.targets.size());
  for (const auto& m : b.targets)
    out.i32(m.target), out.vec2(m.value), out.mat2(m.covariance), out.u8(m.kind);
  out.boolean(b.fix.has_value());
  if (b.fix) out.vec2(b.fix->position_m), out.mat2(b.fix->covariance);
  out.boolean(b.motion.has_value());
  if (b.motion) out.vec2(b.motion->velocity_mps), out.f64(b.motion->dt_s), out.mat2(b.motion->process_cov);
  out.boolean(b.odometry.has_value());
  if (b.odometry) {
    out.count(b.odometry->segments.size());
    for (const auto& s : b.odometry->segments) out.f64(s.v_mps), out.f64(s.omega_radps), out.f64(s.dt_s);
    out.f64(b.odometry->v_std);
    out.f64(b.odometry->omega_std);
  }
  out.count(b.range_bearings.size());
  for (const auto& m : b.range_bearings) {
    out.i32(m.peer), out.boolean(m.landmark), out.vec2(m.landmark_m), out.mat2(m.landmark_cov);
    out.f64(m.range_m), out.f64(m.bearing_rad), out.f64(m.range_std_m), out.f64(m.bearing_std_rad);
  }
  out.count(b.neighbours.size());
  for (AgentId j : b.neighbours) out.i32(j);
}

void encode(Encoder& out, const estimators::StateMessage& m) {
  out.vec2(m.mean_m), out.mat2(m.covariance), out.boolean(m.anchor), out.boolean(m.active), out.u16(m.degree);
  out.count(m.edge_ranges.size());  // version 5
  for (const auto& edge : m.edge_ranges)
    out.i32(edge.peer), out.f64(edge.information), out.f64(edge.mean_range_m);
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

/// `path` after creating its parent directories (OutputError naming the directory if that fails).
const std::filesystem::path& with_parent_directories(const std::filesystem::path& path) {
  if (path.has_parent_path()) {
    std::error_code error;
    std::filesystem::create_directories(path.parent_path(), error);
    if (error) throw OutputError(path.parent_path(), "create the directory", error.value());
  }
  return path;
}

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
    if (version >= kFirstChecksummedRecordingVersion && version <= kRecordingVersion) {
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
    if (version < kOldestReadableRecordingVersion || version > kRecordingVersion) {
      fail("format version " + std::to_string(version) + " is not supported (this build reads versions " +
               std::to_string(kOldestReadableRecordingVersion) + " to " + std::to_string(kRecordingVersion) +
               ")",
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
    for (int k = 0; k < width; ++k) v |= static_cast<std::uint64_t>(bytes_[offset_ + k]) << (8 * k);
    offset_ += static_cast<std::size_t>(width);
    return v;
  }

  const std::vector<std::uint8_t>& bytes_;
  std::string source_;
  std::size_t limit_;  ///< the end of the current version 4 payload, else of the file
  std::size_t offset_ = 0;
  bool ran_out_ = false;
};

// Smallest encodings, for Decoder::count.
constexpr std::size_t kRangeBytes = 4 + 8 + 8;
constexpr std::size_t kRelativeBytes = 4 + 16 + 32;
constexpr std::size_t kPathBytes = 4 + 4 + 24;
constexpr std::size_t kTargetBytes = 4 + 16 + 32 + 1;
constexpr std::size_t kSegmentBytes = 24;
constexpr std::size_t kRangeBearingBytes = 4 + 1 + 16 + 32 + 32;

estimators::MeasurementBatch decode_batch(Decoder& in, int agents) {
  estimators::MeasurementBatch b;
  b.world_step = in.i64();
  b.world_time_s = in.f64();
  b.ranges.resize(in.count(kRangeBytes, "ranges"));
  for (auto& m : b.ranges) {
    m.peer = in.agent(agents, "range peer");
    m.range_m = in.f64(), m.std_m = in.f64();
  }
  b.bearings.resize(in.count(kRangeBytes, "bearings"));
  for (auto& m : b.bearings) {
    m.peer = in.agent(agents, "bearing peer");
    m.bearing_rad = in.f64(), m.std_rad = in.f64();
  }
  b.relative.resize(in.count(kRelativeBytes, "relative positions"));
  for (auto& m : b.relative) {
    m.peer = in.agent(agents, "relative-position peer");
    m.delta_m = in.vec2(), m.covariance = in.mat2();
  }
  b.paths.resize(in.count(kPathBytes, "paths"));
  for (auto& m : b.paths) {
    m.peer = in.agent(agents, "path peer");
    m.path_index = in.i32();
    m.length_m = in.f64(), m.aoa_here_rad = in.f64(), m.aoa_there_rad = in.f64();
  }
  b.targets.resize(in.count(kTargetBytes, "target observations"));
  for (auto& m : b.targets) {
    m.target = in.i32();
    m.value = in.vec2(), m.covariance = in.mat2();
    m.kind = in.u8();
  }
  if (in.boolean()) {
    estimators::AbsoluteFix fix;
    fix.position_m = in.vec2(), fix.covariance = in.mat2();
    b.fix = fix;
  }
  if (in.boolean()) {
    estimators::MotionInput motion;
    motion.velocity_mps = in.vec2(), motion.dt_s = in.f64(), motion.process_cov = in.mat2();
    b.motion = motion;
  }
  if (in.boolean()) {
    estimators::OdometryInput odometry;
    odometry.segments.resize(in.count(kSegmentBytes, "odometry segments"));
    for (auto& s : odometry.segments) s.v_mps = in.f64(), s.omega_radps = in.f64(), s.dt_s = in.f64();
    odometry.v_std = in.f64(), odometry.omega_std = in.f64();
    b.odometry = std::move(odometry);
  }
  b.range_bearings.resize(in.count(kRangeBearingBytes, "range-bearing measurements"));
  for (auto& m : b.range_bearings) {
    const auto peer_at = in.offset();
    m.peer = in.i32();
    m.landmark = in.boolean();
    if (!m.landmark && (m.peer < 0 || m.peer >= agents)) {
      in.fail("range-bearing peer " + std::to_string(m.peer) + " outside [0, " + std::to_string(agents) + ")",
              peer_at);
    }
    m.landmark_m = in.vec2(), m.landmark_cov = in.mat2();
    m.range_m = in.f64(), m.bearing_rad = in.f64(), m.range_std_m = in.f64(), m.bearing_std_rad = in.f64();
  }
  b.neighbours.resize(in.count(4, "neighbours"));
  for (auto& j : b.neighbours) j = in.agent(agents, "neighbour");
  return b;
}

/// The whole file; RecordingError (naming the path and the OS error) for anything but a readable file.
std::vector<std::uint8_t> read_file(const std::filesystem::path& path) {
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
void decode_into(Decoder& in, estimators::StateMessage& m) {
  m.mean_m = in.vec2(), m.covariance = in.mat2();
  m.anchor = in.boolean(), m.active = in.boolean();
  m.degree = in.u16();
}
template <>
void decode_into(Decoder& in, estimators::InformationMessage& m) {
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
void decode_into(Decoder& in, estimators::ConsensusMessage& m) {
  m.tau = in.i64(), m.round = in.i32();
  m.values.resize(in.count(8, "consensus values"));
  for (auto& v : m.values) v = in.f64();
}
template <>
void decode_into(Decoder& in, estimators::BeliefMessage& m) {
  m.iteration = in.i64(), m.mean_m = in.vec2(), m.information = in.mat2();
  m.infinite_information = in.boolean();
}

}  // namespace

// ---- RecordedWorld ----

RecordedWorld RecordedWorld::of(const World& world) {
  return RecordedWorld{world.is_anchor, world.neighbours, world.initial_guess, world.initial_heading};
}

std::string RecordedWorld::difference(const World& world) const {
  const auto n = is_anchor.size();
  if (static_cast<std::size_t>(world.size()) != n) {
    return "the world has " + std::to_string(world.size()) + " agents, the recording " + std::to_string(n);
  }
  auto same = [](const Vec2& a, const Vec2& b) {
    return std::bit_cast<std::uint64_t>(a.x()) == std::bit_cast<std::uint64_t>(b.x()) &&
           std::bit_cast<std::uint64_t>(a.y()) == std::bit_cast<std::uint64_t>(b.y());
  };
  for (std::size_t i = 0; i < n; ++i) {
    const std::string agent = "agent " + std::to_string(i) + "'s ";
    if (world.is_anchor.at(i) != is_anchor[i]) return agent + "anchor flag differs";
    if (world.neighbours.at(i) != neighbours[i]) return agent + "neighbours differ";
    if (!same(world.initial_guess.at(i), initial_guess[i])) return agent + "initial guess differs";
  }
  if (world.initial_heading != initial_heading) return "the initial headings differ";
  return {};
}

// ---- RecordingWriter ----

RecordingWriter::RecordingWriter(const std::filesystem::path& path, const config::Scenario& scenario,
                                 const World& world)
    : path_(path), out_(with_parent_directories(path)), agents_(world.size()) {
  Encoder e;
  e.text(config::to_yaml(scenario));
  e.i32(agents_);
  for (int i = 0; i < agents_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    e.boolean(world.is_anchor.at(k));
    e.vec2(world.initial_guess.at(k));
    e.count(world.neighbours.at(k).size());
    for (AgentId j : world.neighbours[k]) e.i32(j);
  }
  e.count(world.initial_heading.size());
  for (double heading : world.initial_heading) e.f64(heading);
  out_.write(file_header(kKindRecording));
  write_record(out_, kTagHead, e.bytes());
}

RecordingWriter::~RecordingWriter() {
  try {
    close();
  } catch (const std::exception&) {
    // a destructor must not throw; close() explicitly to see write errors
  }
}

void RecordingWriter::append_step(std::int64_t step, const std::vector<Vec2>& truth,
                                  const std::vector<estimators::MeasurementBatch>& batches) {
  if (closed_) throw std::logic_error("RecordingWriter: append_step after close");
  if (step != steps_) {
    throw std::logic_error("RecordingWriter: step " + std::to_string(step) + " appended, expected " +
                           std::to_string(steps_));
  }
  if (truth.size() != static_cast<std::size_t>(agents_) ||
      batches.size() != static_cast<std::size_t>(agents_)) {
    throw std::logic_error("RecordingWriter: step " + std::to_string(step) + " has " +
                           std::to_string(truth.size()) + " positions and " + std::to_string(batches.size()) +
                           " batches for " + std::to_string(agents_) + " agents");
  }
  Encoder e;
  e.i64(step);
  for (const auto& p : truth) e.vec2(p);
  for (const auto& batch : batches) encode(e, batch);
  write_record(out_, kTagStep, e.bytes());
  ++steps_;
}

void RecordingWriter::close() {
  if (closed_) return;
  closed_ = true;
  Encoder e;
  e.u64(static_cast<std::uint64_t>(steps_));
  write_record(out_, kTagEnd, e.bytes());
  out_.close();
}

// ---- Recording ----

std::vector<Vec2> Recording::truth(std::int64_t step) const {
  if (step < 0 || step >= steps()) {
    throw std::out_of_range(source_ + ": step " + std::to_string(step) + " is not recorded (it holds " +
                            std::to_string(steps()) + " steps)");
  }
  return truth_[static_cast<std::size_t>(step)];
}

estimators::MeasurementBatch Recording::batch(AgentId agent, std::int64_t step) const {
  if (step < 0 || step >= steps() || agent < 0 || agent >= agents_) {
    throw std::out_of_range(source_ + ": no batch of agent " + std::to_string(agent) + " at step " +
                            std::to_string(step) + " (" + std::to_string(agents_) + " agents, " +
                            std::to_string(steps()) + " steps)");
  }
  Decoder in(bytes_, source_);
  in.seek(batch_offsets_[static_cast<std::size_t>(step) * static_cast<std::size_t>(agents_) +
                         static_cast<std::size_t>(agent)]);
  return decode_batch(in, agents_);
}

std::shared_ptr<const Recording> load_recording(const std::filesystem::path& path) {
  return parse_recording(read_file(path), path.string());
}

std::shared_ptr<const Recording> parse_recording(std::vector<std::uint8_t> bytes, const std::string& source) {
  auto recording = std::make_shared<Recording>();
  Recording& r = *recording;
  r.source_ = source;
  r.bytes_ = std::move(bytes);
  Decoder in(r.bytes_, source);
  r.version_ = in.file_header(kKindRecording);
  const bool checksummed = r.version_ >= kFirstChecksummedRecordingVersion;
  Decoder::Record head;
  if (checksummed) {
    head = in.begin_record();
    if (head.tag != kTagHead)
      in.fail("expected the header record ('H'), found the " + tag_name(head.tag), head.at);
  }
  r.scenario_yaml_ = in.text(kMaxScenarioBytes, "scenario");
  const auto agents_at = in.offset();
  r.agents_ = in.i32();
  if (r.agents_ < 1 || r.agents_ > kMaxAgents) {
    in.fail("agent count " + std::to_string(r.agents_) + " outside [1, " + std::to_string(kMaxAgents) + "]",
            agents_at);
  }
  const auto n = static_cast<std::size_t>(r.agents_);
  constexpr std::size_t kAgentBytes = 1 + 16 + 4;
  if (n > in.left() / kAgentBytes)
    in.fail("agent count " + std::to_string(n) + " exceeds the bytes left", agents_at);
  auto& world = r.world_;
  world.is_anchor.resize(n);
  world.initial_guess.resize(n);
  world.neighbours.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    world.is_anchor[i] = in.boolean();
    world.initial_guess[i] = in.vec2();
    world.neighbours[i].resize(in.count(4, "neighbours"));
    for (auto& j : world.neighbours[i]) {
      const auto at = in.offset();
      j = in.agent(r.agents_, "neighbour");
      if (static_cast<std::size_t>(j) == i)
        in.fail("agent " + std::to_string(i) + " is its own neighbour", at);
    }
  }
  const auto headings_at = in.offset();
  world.initial_heading.resize(in.count(8, "initial headings"));
  if (!world.initial_heading.empty() && world.initial_heading.size() != n) {
    in.fail(std::to_string(world.initial_heading.size()) + " initial headings for " + std::to_string(n) +
                " agents",
            headings_at);
  }
  for (auto& heading : world.initial_heading) heading = in.f64();
  if (checksummed) in.end_record(head);

  // The smallest step after its tag: the step number, the truth, N empty batches.
  const std::size_t step_min_bytes = 8 + n * (16 + 8 + 8 + 6 * 4 + 3);
  for (;;) {
    const auto tag_at = in.offset();
    Decoder::Record record;
    if (checksummed) record = in.begin_record();
    const std::uint8_t tag = checksummed ? record.tag : in.u8();
    if (tag == kTagEnd) {
      const auto count_at = in.offset();
      const std::uint64_t steps = in.u64();
      if (steps != r.truth_.size()) {
        in.fail("end marker counts " + std::to_string(steps) + " steps, the file holds " +
                    std::to_string(r.truth_.size()),
                count_at);
      }
      if (checksummed) in.end_record(record);
      if (!in.at_end()) in.fail(std::to_string(in.bytes_left_in_file()) + " bytes after the end marker");
      break;
    }
    if (tag != kTagStep)
      in.fail("expected a step ('T') or the end marker ('E'), found byte " + std::to_string(tag), tag_at);
    if (in.left() < step_min_bytes)
      in.fail("truncated: step " + std::to_string(r.truth_.size()) + " is incomplete", tag_at);
    const auto step_at = in.offset();
    const std::int64_t step = in.i64();
    if (step != static_cast<std::int64_t>(r.truth_.size())) {
      in.fail(
          "step " + std::to_string(step) + " where step " + std::to_string(r.truth_.size()) + " was expected",
          step_at);
    }
    std::vector<Vec2> truth(n);
    for (auto& p : truth) p = in.vec2();
    r.truth_.push_back(std::move(truth));
    for (std::size_t i = 0; i < n; ++i) {
      r.batch_offsets_.push_back(in.offset());
      const auto batch = decode_batch(in, r.agents_);  // validates; decoded again on demand
      if (batch.odometry || !batch.range_bearings.empty()) r.has_pose_measurements_ = true;
    }
    if (checksummed) in.end_record(record);
  }
  return recording;
}

// ---- Sample logs ----

const char* to_string(SampleFamily family) {
  switch (family) {
    case SampleFamily::kState:
      return "state";
    case SampleFamily::kInformation:
      return "information";
    case SampleFamily::kConsensus:
      return "consensus";
    case SampleFamily::kBelief:
      return "belief";
  }
  return "unknown";
}

SampleLogWriter::SampleLogWriter(const std::filesystem::path& path, int agent_count,
                                 std::uint64_t scenario_hash)
    : path_(path), out_(with_parent_directories(path)) {
  Encoder e;
  e.i32(agent_count);
  e.u64(scenario_hash);
  out_.write(file_header(kKindSampleLog));
  write_record(out_, kTagHead, e.bytes());
}

SampleLogWriter::~SampleLogWriter() {
  try {
    close();
  } catch (const std::exception&) {
    // a destructor must not throw; close() explicitly to see write errors
  }
}

void SampleLogWriter::append(const ReceivedSample& s) {
  if (closed_) throw std::logic_error("SampleLogWriter: append after close");
  Encoder e;
  e.i32(s.receiver);
  e.i64(s.receiver_steps);
  e.i64(s.source_timestamp_ns);
  e.i64(s.take_ns);
  e.boolean(s.well_formed);
  e.i32(s.header.agent_id), e.u32(s.header.seq), e.i64(s.header.step);
  e.i64(s.header.sender_stamp_ns), e.i64(s.header.world_stamp_ns);
  e.u8(static_cast<std::uint8_t>(s.family()));
  std::visit([&](const auto& message) { encode(e, message); }, s.message);
  write_record(out_, kTagSample, e.bytes());
  ++count_;
}

void SampleLogWriter::close() {
  if (closed_) return;
  closed_ = true;
  Encoder e;
  e.u64(count_);
  write_record(out_, kTagEnd, e.bytes());
  out_.close();
}

SampleLog load_sample_log(const std::filesystem::path& path, bool allow_unfinished) {
  return parse_sample_log(read_file(path), path.string(), allow_unfinished);
}

namespace {

/// A sample record's fields after its tag ('R'); `version` decides which payload fields exist.
ReceivedSample decode_sample(Decoder& in, int agents, std::uint16_t version) {
  ReceivedSample s;
  s.receiver = in.agent(agents, "receiver");
  s.receiver_steps = in.i64();
  s.source_timestamp_ns = in.i64();
  s.take_ns = in.i64();
  s.well_formed = in.boolean();
  s.header.agent_id = in.i32(), s.header.seq = in.u32(), s.header.step = in.i64();
  s.header.sender_stamp_ns = in.i64(), s.header.world_stamp_ns = in.i64();
  const auto family_at = in.offset();
  switch (in.u8()) {
    case 0: {
      auto& state = s.message.emplace<estimators::StateMessage>();
      decode_into(in, state);
      if (version >= 5) {  // older logs predate dml's edge summaries
        state.edge_ranges.resize(in.count(4 + 2 * 8, "edge ranges"));
        for (auto& edge : state.edge_ranges)
          edge.peer = in.i32(), edge.information = in.f64(), edge.mean_range_m = in.f64();
      }
      break;
    }
    case 1: {
      auto& information = s.message.emplace<estimators::InformationMessage>();
      decode_into(in, information);
      if (version >= 2) information.world_step = in.i64();  // version 1 logs predate it: −1
      break;
    }
    case 2:
      decode_into(in, s.message.emplace<estimators::ConsensusMessage>());
      break;
    case 3: {
      auto& belief = s.message.emplace<estimators::BeliefMessage>();
      decode_into(in, belief);
      if (version >= 3) {  // older logs predate exact GaBP's contributions
        belief.contributions.resize(in.count(4 + 6 * 8, "belief contributions"));
        for (auto& c : belief.contributions)
          c.from = in.i32(), c.information = in.mat2(), c.info_vec = in.vec2();
      }
      break;
    }
    default:
      in.fail("unknown sample family", family_at);
  }
  return s;
}

}  // namespace

SampleLog parse_sample_log(const std::vector<std::uint8_t>& bytes, const std::string& source,
                           bool allow_unfinished) {
  SampleLog log;
  Decoder in(bytes, source);
  log.version = in.file_header(kKindSampleLog);
  const bool checksummed = log.version >= kFirstChecksummedRecordingVersion;
  Decoder::Record head;
  if (checksummed) {
    head = in.begin_record();
    if (head.tag != kTagHead)
      in.fail("expected the header record ('H'), found the " + tag_name(head.tag), head.at);
  }
  const auto agents_at = in.offset();
  log.agents = in.i32();
  if (log.agents < 1 || log.agents > kMaxAgents) {
    in.fail("agent count " + std::to_string(log.agents) + " outside [1, " + std::to_string(kMaxAgents) + "]",
            agents_at);
  }
  log.scenario_hash = in.u64();
  if (checksummed) in.end_record(head);
  for (;;) {
    const auto record_at = in.offset();
    if (allow_unfinished && in.at_end()) {
      log.complete = false;  // cut at a record boundary
      return log;
    }
    try {
      Decoder::Record record;
      if (checksummed) record = in.begin_record();
      const std::uint8_t tag = checksummed ? record.tag : in.u8();
      if (tag == kTagEnd) {
        const auto count_at = in.offset();
        const std::uint64_t count = in.u64();
        if (count != log.samples.size()) {
          in.fail("end marker counts " + std::to_string(count) + " samples, the file holds " +
                      std::to_string(log.samples.size()),
                  count_at);
        }
        if (checksummed) in.end_record(record);
        if (!in.at_end()) in.fail(std::to_string(in.bytes_left_in_file()) + " bytes after the end marker");
        return log;
      }
      if (tag != kTagSample) {
        in.fail("expected a sample ('R') or the end marker ('E'), found byte " + std::to_string(tag),
                record_at);
      }
      log.samples.push_back(decode_sample(in, log.agents, log.version));
      if (checksummed) in.end_record(record);
    } catch (const RecordingError&) {
      // An unfinished file (a killed writer) ends in a cut record: keep what came before it. Since
      // version 4 only a record the file's end cuts counts; a damaged one is an error.
      if (!allow_unfinished || !in.ran_out()) throw;
      log.complete = false;
      return log;
    }
  }
}

// ---- DirectoryRecorder ----

void DirectoryRecorder::begin(const config::Scenario& scenario, const World& world) {
  steps_ = std::make_unique<RecordingWriter>(run_dir_ / kRecordingFile, scenario, world);
  samples_ = std::make_unique<SampleLogWriter>(run_dir_ / kSampleLogDirectory / kSimSampleLogFile,
                                               world.size(), config::scenario_hash(scenario));
}

void DirectoryRecorder::world_step(std::int64_t step, const std::vector<Vec2>& truth,
                                   const std::vector<estimators::MeasurementBatch>& batches) {
  if (steps_) steps_->append_step(step, truth, batches);
}

void DirectoryRecorder::sample(const ReceivedSample& sample) {
  if (samples_) samples_->append(sample);
}

void DirectoryRecorder::close() {
  if (steps_) steps_->close();
  if (samples_) samples_->close();
}

}  // namespace swarmloc::sim
