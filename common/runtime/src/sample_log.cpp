// The sample log an agent writes for `run --record` (sample_log.hpp).
#include "swarmloc/runtime/sample_log.hpp"

#include "swarmloc/runtime/slrec_codec.hpp"

namespace swarmloc::runtime {

using namespace slrec;  // NOLINT(google-build-using-namespace): the shared .slrec framing

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
    case SampleFamily::kObservations:
      return "observations";
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

}  // namespace swarmloc::runtime
