#pragma once
// A recording's bytes as the tests read them, written out independently of recording.cpp
// (docs/record-replay.md): the version 4 framing (a CRC-32 per header and per record), the same content in
// the unchecksummed layout of versions 1 to 3, and bit-for-bit comparison of doubles. Shared by the
// recording tests (tests/unit/rundir/test_recording.cpp) and the simulator's replays of recordings
// (tests/unit/sim/test_simulated_recording.cpp).
#include <gtest/gtest.h>

#include <bit>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace swarmloc::testing {

/// CRC-32 (IEEE, reflected, as zlib's crc32), bit by bit.
inline std::uint32_t crc32_ieee(const std::uint8_t* data, std::size_t size) {
  std::uint32_t crc = 0xFFFFFFFFu;
  for (std::size_t k = 0; k < size; ++k) {
    crc ^= data[k];
    for (int bit = 0; bit < 8; ++bit) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

inline std::uint32_t get_u32(const std::vector<std::uint8_t>& bytes, std::size_t at) {
  std::uint32_t v = 0;
  for (int k = 0; k < 4; ++k)
    v |= static_cast<std::uint32_t>(bytes[at + static_cast<std::size_t>(k)]) << (8 * k);
  return v;
}
inline void put_u32(std::vector<std::uint8_t>& bytes, std::size_t at, std::uint32_t v) {
  for (int k = 0; k < 4; ++k)
    bytes[at + static_cast<std::size_t>(k)] = static_cast<std::uint8_t>(v >> (8 * k));
}

/// A version 4 record: tag, u32 length, u32 CRC of those 5 bytes, payload, u32 CRC of the payload.
struct FramedRecord {
  std::uint8_t tag = 0;
  std::size_t at = 0;
  std::size_t payload_at = 0;
  std::size_t length = 0;
  [[nodiscard]] std::size_t end() const { return payload_at + length + 4; }
};

/// The records of a whole version 4 file (after the 12-byte header), read by their lengths.
inline std::vector<FramedRecord> records_of(const std::vector<std::uint8_t>& bytes) {
  std::vector<FramedRecord> records;
  for (std::size_t at = 12; at + 9 <= bytes.size();) {
    FramedRecord r{bytes[at], at, at + 9, get_u32(bytes, at + 1)};
    if (r.end() > bytes.size()) break;
    records.push_back(r);
    at = r.end();
  }
  return records;
}

/// Recomputes every checksum, so that a test can hand the reader a consistent file with a hostile field.
inline void reseal(std::vector<std::uint8_t>& bytes) {
  put_u32(bytes, 8, crc32_ieee(bytes.data(), 8));
  for (const auto& r : records_of(bytes)) {
    put_u32(bytes, r.at + 5, crc32_ieee(bytes.data() + r.at, 5));
    put_u32(bytes, r.payload_at + r.length, crc32_ieee(bytes.data() + r.payload_at, r.length));
  }
}

/// In a sample record's payload: the family byte, and where a state sample's edge summaries (version 5)
/// start (receiver, steps, two stamps, well_formed, header; then family, mean, covariance, flags, degree).
inline constexpr std::size_t kSampleFamilyAt = 4 + 8 + 8 + 8 + 1 + 32;
inline constexpr std::size_t kStateEdgeRangesAt = kSampleFamilyAt + 1 + 16 + 32 + 1 + 1 + 2;

/// The same content in the unchecksummed layout of versions 1 to 3: the 8-byte header, the header
/// record's payload, then per record its tag and payload (a state sample without its edge summaries).
inline std::vector<std::uint8_t> without_checksums(const std::vector<std::uint8_t>& bytes,
                                                   std::uint8_t version) {
  std::vector<std::uint8_t> old(bytes.begin(), bytes.begin() + 8);
  old[6] = version;
  for (const auto& r : records_of(bytes)) {
    if (r.tag != 'H') old.push_back(r.tag);
    const bool state = r.tag == 'R' && bytes[r.payload_at + kSampleFamilyAt] == 0;
    const std::size_t length = state ? kStateEdgeRangesAt : r.length;
    old.insert(old.end(), bytes.begin() + static_cast<std::ptrdiff_t>(r.payload_at),
               bytes.begin() + static_cast<std::ptrdiff_t>(r.payload_at + length));
  }
  return old;
}

/// A double's bits, for comparisons that must hold bit for bit (NaN included).
inline std::uint64_t bits(double v) { return std::bit_cast<std::uint64_t>(v); }

}  // namespace swarmloc::testing

#define EXPECT_BITS(a, b) EXPECT_EQ(::swarmloc::testing::bits(a), ::swarmloc::testing::bits(b)) << #a
