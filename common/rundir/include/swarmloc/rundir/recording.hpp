#pragma once
// `--record` and `swarmloc replay` (docs/record-replay.md): a compact, versioned, little-endian binary
// file of everything the world fed the agents — the scenario as run, the world at step 0, and per
// world step the truth of every agent and every agent's MeasurementBatch (raw doubles, lossless) —
// plus per-receiver logs of the inter-agent samples the agents received. A loaded Recording is a
// RecordedSteps: attached to World::recorded, every runtime replays it unchanged.
//
// Since version 4 every record carries CRC-32 checksums, so a damaged file (one flipped bit anywhere) is
// refused instead of replayed. Readers validate everything (checksums, magic, version, counts against the
// bytes left, agent ids, the end marker) and throw RecordingError naming the file and the byte offset; a
// hostile file never crashes. Writes are checked (OutputFile): a full disk throws instead of leaving a
// silently short file.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/runtime/envelope.hpp"
#include "swarmloc/runtime/output_file.hpp"
#include "swarmloc/runtime/sample_log.hpp"
#include "swarmloc/runtime/slrec_codec.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::rundir {

// kRecordingVersion and the framing: runtime/slrec_codec.hpp.
/// Names in a run directory.
inline constexpr const char* kRecordingFile = "recording.slrec";
inline constexpr const char* kSampleLogDirectory = "recording";
inline constexpr const char* kSimSampleLogFile = "samples.slrec";  ///< the simulator's (every receiver)

/// A file that is not a valid recording or sample log: "<file>: byte <offset>: <what>".
class RecordingError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The world as built at step 0 that a replay must rebuild identically (placement is the truth of
/// step 0, which every step carries anyway).
struct RecordedWorld {
  std::vector<bool> is_anchor;
  std::vector<std::vector<AgentId>> neighbours;
  std::vector<Vec2> initial_guess;
  std::vector<double> initial_heading;  ///< empty or one per agent

  [[nodiscard]] static RecordedWorld of(const world::World& world);
  /// Empty if `world` matches; else what differs first ("agent 3's neighbours differ").
  [[nodiscard]] std::string difference(const world::World& world) const;
};

/// Writes recording.slrec step by step. Steps must come in order 0, 1, 2, …; close() writes the end
/// marker (a file without it — an interrupted run — is reported as truncated by the reader).
class RecordingWriter {
 public:
  /// Creates `path` (and its parent directories) and writes the header. Throws OutputError (a
  /// std::runtime_error naming the file and the OS error) if it cannot.
  RecordingWriter(const std::filesystem::path& path, const config::Scenario& scenario,
                  const world::World& world);
  ~RecordingWriter();
  RecordingWriter(const RecordingWriter&) = delete;
  RecordingWriter& operator=(const RecordingWriter&) = delete;

  /// World step `step` (== steps()): the truth and the batch of every agent (one per agent, in id order).
  /// Throws OutputError if the write fails.
  void append_step(std::int64_t step, const std::vector<Vec2>& truth,
                   const std::vector<estimators::MeasurementBatch>& batches);
  /// Writes the end marker and flushes; idempotent. Throws OutputError if a write, the flush or the
  /// close failed (e.g. "No space left on device").
  void close();
  [[nodiscard]] std::int64_t steps() const { return steps_; }
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  runtime::OutputFile out_;
  int agents_ = 0;
  std::int64_t steps_ = 0;
  bool closed_ = false;
};

/// A loaded recording. Batches are decoded on demand from the validated bytes (a decoded
/// MeasurementBatch is several times larger than its encoding).
class Recording final : public world::RecordedSteps {
 public:
  [[nodiscard]] std::int64_t steps() const override { return static_cast<std::int64_t>(truth_.size()); }
  /// Throws std::out_of_range for a step outside [0, steps()).
  [[nodiscard]] std::vector<Vec2> truth(std::int64_t step) const override;
  /// Throws std::out_of_range for an agent or step out of range.
  [[nodiscard]] estimators::MeasurementBatch batch(AgentId agent, std::int64_t step) const override;

  [[nodiscard]] const std::string& source() const { return source_; }
  [[nodiscard]] std::uint16_t version() const { return version_; }
  [[nodiscard]] const std::string& scenario_yaml() const { return scenario_yaml_; }
  [[nodiscard]] int agents() const { return agents_; }
  [[nodiscard]] const RecordedWorld& world() const { return world_; }
  /// Some batch carries odometry or range-bearing measurements (not on the DDS wire yet).
  [[nodiscard]] bool has_pose_measurements() const { return has_pose_measurements_; }

 private:
  friend std::shared_ptr<const Recording> parse_recording(std::vector<std::uint8_t> bytes,
                                                          const std::string& source);
  std::string source_;
  std::uint16_t version_ = 0;
  std::string scenario_yaml_;
  int agents_ = 0;
  RecordedWorld world_;
  std::vector<std::vector<Vec2>> truth_;    ///< per step
  std::vector<std::uint8_t> bytes_;         ///< the whole file
  std::vector<std::size_t> batch_offsets_;  ///< step · agents + agent → offset of its batch in bytes_
  bool has_pose_measurements_ = false;
};

/// Reads and validates a recording file. Throws RecordingError (a path that is a directory or cannot be
/// read, a checksum mismatch, bad magic or version, truncation, counts larger than the bytes left, agent
/// ids out of range, trailing bytes).
std::shared_ptr<const Recording> load_recording(const std::filesystem::path& path);
/// The same for a file's bytes; `source` names it in errors.
std::shared_ptr<const Recording> parse_recording(std::vector<std::uint8_t> bytes, const std::string& source);

// ---- Inter-agent samples ----

// SampleMessage, ReceivedSample, SampleLogWriter: runtime/sample_log.hpp.

struct SampleLog {
  std::uint16_t version = 0;
  int agents = 0;
  std::uint64_t scenario_hash = 0;
  /// False: the writer never closed the file (a killed agent); samples are the records written in full.
  bool complete = true;
  std::vector<runtime::ReceivedSample> samples;
};

/// Reads and validates a sample log. `allow_unfinished`: a file without its end marker (a killed
/// process) yields the complete records before the cut, with complete = false, instead of an error. A
/// damaged record (checksum mismatch) is an error in either case; only a record cut by the end of the
/// file counts as the cut.
SampleLog load_sample_log(const std::filesystem::path& path, bool allow_unfinished = false);
SampleLog parse_sample_log(const std::vector<std::uint8_t>& bytes, const std::string& source,
                           bool allow_unfinished = false);

// ---- What the simulator hands to --record ----

/// A runtime's --record sink: the world once before step 0, then every world step's truth and batches
/// and every inter-agent sample an agent receives.
class RunRecorder {
 public:
  virtual ~RunRecorder() = default;
  virtual void begin(const config::Scenario& scenario, const world::World& world) = 0;
  virtual void world_step(std::int64_t step, const std::vector<Vec2>& truth,
                          const std::vector<estimators::MeasurementBatch>& batches) = 0;
  virtual void sample(const runtime::ReceivedSample& sample) = 0;
};

/// Writes <run_dir>/recording.slrec and <run_dir>/recording/samples.slrec.
class DirectoryRecorder final : public RunRecorder {
 public:
  explicit DirectoryRecorder(std::filesystem::path run_dir) : run_dir_(std::move(run_dir)) {}
  void begin(const config::Scenario& scenario, const world::World& world) override;
  void world_step(std::int64_t step, const std::vector<Vec2>& truth,
                  const std::vector<estimators::MeasurementBatch>& batches) override;
  void sample(const runtime::ReceivedSample& sample) override;
  /// Closes both files. Throws OutputError if a write failed.
  void close();
  [[nodiscard]] std::int64_t steps() const { return steps_ ? steps_->steps() : 0; }
  [[nodiscard]] std::uint64_t samples() const { return samples_ ? samples_->count() : 0; }

 private:
  std::filesystem::path run_dir_;
  std::unique_ptr<RecordingWriter> steps_;
  std::unique_ptr<runtime::SampleLogWriter> samples_;
};

}  // namespace swarmloc::rundir
