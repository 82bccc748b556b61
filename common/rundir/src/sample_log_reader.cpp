// Reading sample logs (recording.hpp; the writer is runtime/sample_log.cpp).
#include "slrec_decoder.hpp"

namespace swarmloc::rundir {

using namespace runtime::slrec;  // NOLINT(google-build-using-namespace): the shared .slrec framing
using namespace slrec;           // NOLINT(google-build-using-namespace): its decoder

SampleLog load_sample_log(const std::filesystem::path& path, bool allow_unfinished) {
  return parse_sample_log(read_file(path), path.string(), allow_unfinished);
}

namespace {

/// A sample record's fields after its tag ('R'); `version` decides which payload fields exist.
runtime::ReceivedSample decode_sample(Decoder& in, int agents, std::uint16_t version) {
  runtime::ReceivedSample s;
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
        state.edge_ranges.resize(in.count(version >= 6 ? 4 + 4 * 8 : 4 + 2 * 8, "edge ranges"));
        for (auto& edge : state.edge_ranges) {
          edge.peer = in.i32(), edge.information = in.f64(), edge.mean_range_m = in.f64();
          if (version >= 6) edge.peer_mean_m = in.vec2();
        }
      }
      if (version >= 8) state.inconsistent = in.boolean();  // older logs predate dml's flag
      if (version >= 9) {                                   // older logs predate dml's cavities
        state.cavities.resize(in.count(4 + 4 * 8, "cavities"));
        for (auto& cavity : state.cavities) {
          cavity.peer = in.i32(), cavity.offset_m = in.vec2(), cavity.offset_z_m = in.f64();
          cavity.variance_m2 = in.f64();
        }
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
    case 4:
      if (version < 7)
        in.fail("an observations sample in a version " + std::to_string(version) + " log", family_at);
      decode_into(in, s.message.emplace<estimators::ObservationMessage>());
      break;
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
  const bool checksummed = log.version >= runtime::kFirstChecksummedRecordingVersion;
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

}  // namespace swarmloc::rundir
