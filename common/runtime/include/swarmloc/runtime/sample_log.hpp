#pragma once
// The inter-agent samples an agent received, as logged by `run --record` (DDS: recording/agent_<id>.slrec
// per agent process; the simulator: recording/samples.slrec for every receiver). Readers:
// rundir/recording.hpp (load_sample_log).
#include <cstdint>
#include <filesystem>
#include <variant>

#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/runtime/envelope.hpp"
#include "swarmloc/runtime/output_file.hpp"

namespace swarmloc::runtime {

using SampleMessage =
    std::variant<estimators::StateMessage, estimators::InformationMessage, estimators::ConsensusMessage,
                 estimators::BeliefMessage, estimators::ObservationMessage>;
/// The family of a SampleMessage (its variant index).
enum class SampleFamily : std::uint8_t {
  kState = 0,
  kInformation = 1,
  kConsensus = 2,
  kBelief = 3,
  kObservations = 4
};
const char* to_string(SampleFamily family);

/// One inter-agent sample as an agent received it (before loss injection and validation).
struct ReceivedSample {
  AgentId receiver = 0;
  std::int64_t receiver_steps = 0;  ///< steps the receiver had run when it took the sample
  /// DDS: the writer's source timestamp and the receiver's dds_time() at take (real-time clock, ns).
  /// Simulator: virtual time of the publication and of the delivery (ns since the run's start).
  std::int64_t source_timestamp_ns = 0;
  std::int64_t take_ns = 0;
  bool well_formed = true;  ///< false: the wire sample was malformed (the message is what decoded)
  Header header;            ///< sender (agent_id), seq, the sender's step, its stamps
  SampleMessage message;

  [[nodiscard]] SampleFamily family() const { return static_cast<SampleFamily>(message.index()); }
};

/// Appends received samples to a sample log (DDS: recording/agent_<id>.slrec per agent process; the
/// simulator: recording/samples.slrec for every receiver).
class SampleLogWriter {
 public:
  /// Throws OutputError if `path` cannot be created.
  SampleLogWriter(const std::filesystem::path& path, int agent_count, std::uint64_t scenario_hash);
  ~SampleLogWriter();
  SampleLogWriter(const SampleLogWriter&) = delete;
  SampleLogWriter& operator=(const SampleLogWriter&) = delete;

  /// Throws OutputError if the write fails.
  void append(const ReceivedSample& sample);
  /// Writes the end marker and flushes; idempotent. Throws OutputError if a write failed.
  void close();
  [[nodiscard]] std::uint64_t count() const { return count_; }

 private:
  std::filesystem::path path_;
  OutputFile out_;
  std::uint64_t count_ = 0;
  bool closed_ = false;
};

}  // namespace swarmloc::runtime
