// Binary recordings and sample logs (recording.hpp; the format is described in docs/record-replay.md).
#include "swarmloc/rundir/recording.hpp"

#include <zlib.h>

#include <bit>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <limits>
#include <system_error>

#include "slrec_decoder.hpp"

namespace swarmloc::rundir {

using namespace runtime::slrec;  // NOLINT(google-build-using-namespace): the shared .slrec framing
using namespace slrec;           // NOLINT(google-build-using-namespace): its decoder

namespace {

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

}  // namespace

// ---- RecordedWorld ----

RecordedWorld RecordedWorld::of(const world::World& world) {
  return RecordedWorld{world.is_anchor, world.neighbours, world.initial_guess, world.initial_heading};
}

std::string RecordedWorld::difference(const world::World& world) const {
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
                                 const world::World& world)
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

namespace {

/// The header record's agent count, checked against the limit and the bytes left.
int decode_agent_count(Decoder& in) {
  const auto agents_at = in.offset();
  const int agents = in.i32();
  if (agents < 1 || agents > kMaxAgents) {
    in.fail("agent count " + std::to_string(agents) + " outside [1, " + std::to_string(kMaxAgents) + "]",
            agents_at);
  }
  const auto n = static_cast<std::size_t>(agents);
  constexpr std::size_t kAgentBytes = 1 + 16 + 4;
  if (n > in.left() / kAgentBytes)
    in.fail("agent count " + std::to_string(n) + " exceeds the bytes left", agents_at);
  return agents;
}

/// The header record's per-agent setup (anchor flag, initial guess, neighbours) and initial headings.
void decode_recorded_world(Decoder& in, int agents, RecordedWorld& world) {
  const auto n = static_cast<std::size_t>(agents);
  world.is_anchor.resize(n);
  world.initial_guess.resize(n);
  world.neighbours.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    world.is_anchor[i] = in.boolean();
    world.initial_guess[i] = in.vec2();
    world.neighbours[i].resize(in.count(4, "neighbours"));
    for (auto& j : world.neighbours[i]) {
      const auto at = in.offset();
      j = in.agent(agents, "neighbour");
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
}

/// The end marker's body: its step count must match the steps read, and nothing may follow it.
void decode_end_marker(Decoder& in, std::size_t steps_read, bool checksummed, const Decoder::Record& record) {
  const auto count_at = in.offset();
  const std::uint64_t steps = in.u64();
  if (steps != steps_read) {
    in.fail(
        "end marker counts " + std::to_string(steps) + " steps, the file holds " + std::to_string(steps_read),
        count_at);
  }
  if (checksummed) in.end_record(record);
  if (!in.at_end()) in.fail(std::to_string(in.bytes_left_in_file()) + " bytes after the end marker");
}

/// A step record's body after its tag: the step number, the truth, and every agent's batch, which is
/// validated here and only indexed (decoded again on demand). True if a batch carries pose measurements.
bool decode_step(Decoder& in, int agents, std::size_t tag_at, std::vector<std::vector<Vec2>>& truth_per_step,
                 std::vector<std::size_t>& batch_offsets) {
  const auto n = static_cast<std::size_t>(agents);
  // The smallest step after its tag: the step number, the truth, N empty batches.
  const std::size_t step_min_bytes = 8 + n * (16 + 8 + 8 + 6 * 4 + 3);
  if (in.left() < step_min_bytes)
    in.fail("truncated: step " + std::to_string(truth_per_step.size()) + " is incomplete", tag_at);
  const auto step_at = in.offset();
  const std::int64_t step = in.i64();
  if (step != static_cast<std::int64_t>(truth_per_step.size())) {
    in.fail("step " + std::to_string(step) + " where step " + std::to_string(truth_per_step.size()) +
                " was expected",
            step_at);
  }
  std::vector<Vec2> truth(n);
  for (auto& p : truth) p = in.vec2();
  truth_per_step.push_back(std::move(truth));
  bool has_pose_measurements = false;
  for (std::size_t i = 0; i < n; ++i) {
    batch_offsets.push_back(in.offset());
    const auto batch = decode_batch(in, agents);  // validates; decoded again on demand
    if (batch.odometry || !batch.range_bearings.empty()) has_pose_measurements = true;
  }
  return has_pose_measurements;
}

}  // namespace

std::shared_ptr<const Recording> parse_recording(std::vector<std::uint8_t> bytes, const std::string& source) {
  auto recording = std::make_shared<Recording>();
  Recording& r = *recording;
  r.source_ = source;
  r.bytes_ = std::move(bytes);
  Decoder in(r.bytes_, source);
  r.version_ = in.file_header(kKindRecording);
  const bool checksummed = r.version_ >= runtime::kFirstChecksummedRecordingVersion;
  Decoder::Record head;
  if (checksummed) {
    head = in.begin_record();
    if (head.tag != kTagHead)
      in.fail("expected the header record ('H'), found the " + tag_name(head.tag), head.at);
  }
  r.scenario_yaml_ = in.text(kMaxScenarioBytes, "scenario");
  r.agents_ = decode_agent_count(in);
  decode_recorded_world(in, r.agents_, r.world_);
  if (checksummed) in.end_record(head);

  for (;;) {
    const auto tag_at = in.offset();
    Decoder::Record record;
    if (checksummed) record = in.begin_record();
    const std::uint8_t tag = checksummed ? record.tag : in.u8();
    if (tag == kTagEnd) {
      decode_end_marker(in, r.truth_.size(), checksummed, record);
      break;
    }
    if (tag != kTagStep)
      in.fail("expected a step ('T') or the end marker ('E'), found byte " + std::to_string(tag), tag_at);
    if (decode_step(in, r.agents_, tag_at, r.truth_, r.batch_offsets_)) r.has_pose_measurements_ = true;
    if (checksummed) in.end_record(record);
  }
  return recording;
}

// ---- DirectoryRecorder ----

void DirectoryRecorder::begin(const config::Scenario& scenario, const world::World& world) {
  steps_ = std::make_unique<RecordingWriter>(run_dir_ / kRecordingFile, scenario, world);
  samples_ = std::make_unique<runtime::SampleLogWriter>(run_dir_ / kSampleLogDirectory / kSimSampleLogFile,
                                                        world.size(), config::scenario_hash(scenario));
}

void DirectoryRecorder::world_step(std::int64_t step, const std::vector<Vec2>& truth,
                                   const std::vector<estimators::MeasurementBatch>& batches) {
  if (steps_) steps_->append_step(step, truth, batches);
}

void DirectoryRecorder::sample(const runtime::ReceivedSample& sample) {
  if (samples_) samples_->append(sample);
}

void DirectoryRecorder::close() {
  if (steps_) steps_->close();
  if (samples_) samples_->close();
}

}  // namespace swarmloc::rundir
