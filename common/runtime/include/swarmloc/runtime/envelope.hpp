#pragma once
// What a runtime (simulator bus or DDS) attaches to every sample, and what an agent reports for
// scoring. Transport-free: the DDS layer converts these to and from IDL in one file.
#include <array>
#include <cstdint>
#include <vector>

#include "swarmloc/core/link_model.hpp"
#include "swarmloc/estimators/messages.hpp"

namespace swarmloc::runtime {

/// The common header of docs/design.md §3.
struct Header {
  AgentId agent_id = 0;
  std::uint32_t seq = 0;
  std::int64_t step = 0;
  std::int64_t sender_stamp_ns = 0;
  std::int64_t world_stamp_ns = 0;
};

/// Why an inbound sample was rejected (counted per reason, never passed to an estimator).
enum class RejectReason : std::uint8_t {
  kNonFinite = 0,    ///< NaN or Inf anywhere
  kNotSymmetricPsd,  ///< covariance not symmetric positive semi-definite
  kAbsurdMagnitude,  ///< |mean| or covariance beyond physical bounds
  kUnknownSender,    ///< not a neighbour / unknown agent id
  kDuplicate,        ///< seq already seen
  kReordered,        ///< older than the newest sample already held
  kMalformed,        ///< wrong sizes, bad enum values
  kCount
};
inline constexpr std::size_t kRejectReasonCount = static_cast<std::size_t>(RejectReason::kCount);
const char* to_string(RejectReason reason);

/// Per inbound link (sender -> this agent) counters.
struct LinkCounters {
  AgentId sender = 0;
  std::uint32_t arrived = 0;
  std::uint32_t delivered = 0;
  std::uint32_t dropped_injected = 0;
  std::uint32_t rejected = 0;
  std::uint32_t first_seq = 0;
  std::uint32_t last_seq = 0;
  /// Delivered samples the sender wrote in a step (header.step >= 0), i.e. not its start-up
  /// announcements, which go out before every neighbour has matched and are expected to be lost.
  std::uint32_t delivered_in_steps = 0;
  /// Samples the sender wrote while this link was up, inferred from the seq range seen.
  [[nodiscard]] std::uint32_t sent() const { return arrived == 0 ? 0 : last_seq - first_seq + 1; }
};

/// An agent's own timing since START (run health, docs/robustness.md), measured by the DDS agent
/// process against its own clock. Zero in the simulator, whose agents have no real time.
struct AgentHealth {
  std::uint32_t ticks = 0;
  std::uint32_t late_ticks = 0;    ///< started more than half a period after their time
  std::uint32_t missed_ticks = 0;  ///< periods skipped after an overrun
  double max_tick_lateness_s = 0.0;
  double mean_tick_lateness_s = 0.0;
  std::uint32_t batches_received = 0;
  std::uint32_t batches_merged = 0;   ///< arrived while an earlier batch still waited for a step
  double max_batch_wait_s = 0.0;      ///< a batch's arrival to the step that used it
  double neighbour_age_mean_s = 0.0;  ///< age of each neighbour's newest sample at a step, mean
  double neighbour_age_max_s = 0.0;
};

/// An agent's report to the orchestrator (the Estimate topic).
struct EstimateReport {
  Header header;
  estimators::Estimate estimate;
  std::uint32_t steps_run = 0;
  std::uint32_t samples_published = 0;
  std::uint32_t samples_published_in_steps = 0;  ///< of those, written in a step (header.step >= 0)
  double cpu_s = 0.0;
  std::vector<LinkCounters> links;
  std::array<std::uint32_t, kRejectReasonCount> rejected_by_reason{};
  std::uint64_t results_hash = 0;  ///< config::results_hash of the agent's scenario (0: not said)
  AgentHealth health;
};

/// kRefuse goes to one agent whose results_hash differs from the run's (scenario_hash: the refused
/// hash, so that a corrected agent restarted under the same id is not refused); the agent exits 2.
enum class ControlCommand : std::uint8_t { kHello = 0, kStart = 1, kStop = 2, kRefuse = 3 };

struct ControlMessage {
  Header header;
  AgentId target = kOrchestratorId;  ///< -1 = everyone
  ControlCommand command = ControlCommand::kHello;
  std::uint64_t scenario_hash = 0;
  std::int64_t start_world_ns = 0;
};

}  // namespace swarmloc::runtime
