#pragma once
// The .slrec framing shared by the recorder (rundir/recording.hpp) and the sample log an agent writes
// (sample_log.hpp): constants, the little-endian encoder, checksummed records and the encoding of the
// inter-agent messages. The format is described in docs/record-replay.md.
#include <cstdint>
#include <filesystem>
#include <limits>
#include <stdexcept>
#include <string>

#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/runtime/output_file.hpp"

namespace swarmloc::runtime {

/// Format version written by this build (both file kinds). Version 2 added an information sample's world
/// step, version 3 a belief sample's contributions (exact GaBP), version 4 checksummed records (a CRC-32
/// of the file header, and of each record's header and payload), version 5 a state sample's edge range
/// summaries (dml), version 6 each summary's peer mean, version 7 observation samples (team_pose_ekf),
/// version 8 a state's self-check flag (dml), version 9 a state's cavities (dml).
/// Readers accept versions 1 to 9 (a version 1 sample's world step reads as −1, an older belief has no
/// contributions, an older state no edge summaries or peer means (zero), no flag and no cavities, files
/// before 4 have no checksums to check).
inline constexpr std::uint16_t kRecordingVersion = 9;
inline constexpr std::uint16_t kOldestReadableRecordingVersion = 1;
inline constexpr std::uint16_t kFirstChecksummedRecordingVersion = 4;

namespace slrec {

inline constexpr char kMagic[5] = {'S', 'L', 'R', 'E', 'C'};
inline constexpr std::uint8_t kKindRecording = 'W';
inline constexpr std::uint8_t kKindSampleLog = 'S';
inline constexpr std::uint8_t kTagHead =
    'H';  // version 4: the world at step 0, or a sample log's agent count
inline constexpr std::uint8_t kTagStep = 'T';
inline constexpr std::uint8_t kTagSample = 'R';
inline constexpr std::uint8_t kTagEnd = 'E';
/// Version 4 framing: the file header's CRC; a record's tag, length and their CRC; the payload's CRC.
inline constexpr std::size_t kFileHeaderBytes = 8;
inline constexpr std::size_t kRecordHeaderBytes = 1 + 4 + 4;
inline constexpr std::size_t kRecordTrailerBytes = 4;

/// zlib's CRC-32 (the IEEE polynomial; it detects every error burst of up to 32 bits).
std::uint32_t crc32_of(const void* data, std::size_t size);
std::string tag_name(std::uint8_t tag);

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
std::string file_header(std::uint8_t kind);
/// One version 4 record: u8 tag, u32 payload length, u32 CRC-32 of those 5 bytes, the payload, u32 CRC-32
/// of the payload. The header's own checksum lets a reader tell a record cut by a kill (a shorter file)
/// from a damaged length.
void write_record(OutputFile& out, std::uint8_t tag, const std::string& payload);

void encode(Encoder& out, const estimators::StateMessage& m);
void encode(Encoder& out, const estimators::InformationMessage& m);
void encode(Encoder& out, const estimators::ConsensusMessage& m);
void encode(Encoder& out, const estimators::BeliefMessage& m);
void encode(Encoder& out, const estimators::ObservationMessage& m);

/// `path` after creating its parent directories (OutputError naming the directory if that fails).
const std::filesystem::path& with_parent_directories(const std::filesystem::path& path);

}  // namespace slrec
}  // namespace swarmloc::runtime
