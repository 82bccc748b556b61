#pragma once
// What a runtime (simulator bus or DDS) attaches to every sample, and what an agent reports for
// scoring. Transport-free: the DDS layer converts these to and from IDL in one file.
#include <array>
#include <cstdint>
#include <vector>

#include "swarmloc/core/link_model.hpp"
#include "swarmloc/estimators/messages.hpp"

namespace swarmloc::sim {

/// The common header of DESIGN.md §3.
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
};

enum class ControlCommand : std::uint8_t { kHello = 0, kStart = 1, kStop = 2 };

struct ControlMessage {
  Header header;
  AgentId target = kOrchestratorId;  ///< -1 = everyone
  ControlCommand command = ControlCommand::kHello;
  std::uint64_t scenario_hash = 0;
  std::int64_t start_world_ns = 0;
};

}  // namespace swarmloc::sim
