#pragma once
// The transport-independent half of an agent: mailbox (newest sample per neighbour), receiver-side
// loss injection, validation of inbound samples, per-link and per-reason counters, and the step that
// calls the estimator. The DDS agent process and the in-process simulator are thin drivers of this
// class, so both run exactly the same code between "a sample arrived" and "publish this".
#include <array>
#include <map>
#include <memory>
#include <optional>
#include <set>

#include "swarmloc/core/link_model.hpp"
#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/sim/envelope.hpp"

namespace swarmloc::sim {

struct AgentRuntimeParams {
  std::uint64_t seed = 1;
  core::LinkLossParams loss;
  double absurd_position_bound_m = 1e6;  ///< |mean| beyond this is rejected
  double absurd_variance_m2 = 1e14;      ///< covariance entries beyond this are rejected
};

class AgentRuntime {
 public:
  AgentRuntime(std::unique_ptr<estimators::Estimator> estimator, estimators::AgentSetup setup,
               std::vector<AgentId> neighbours, AgentRuntimeParams params);

  /// An inter-agent State sample arrived. Applies loss, validation and ordering rules; returns true if
  /// it entered the mailbox.
  bool on_state(const Header& header, const estimators::StateMessage& message, bool well_formed = true);
  /// A measurement batch arrived (batches are not subject to injected loss: they model the sensor).
  /// Entries that cannot come from a real sensor are removed and counted by reason (see sanitize_batch).
  void on_batch(const Header& header, estimators::MeasurementBatch batch);

  /// Runs one local step with the newest data. Returns the messages to publish, with their headers.
  struct Publication {
    Header header;
    estimators::Outbox outbox;
  };
  Publication step(std::int64_t sender_stamp_ns);
  /// The message published before the first step.
  Publication initial_publication(std::int64_t sender_stamp_ns);

  [[nodiscard]] EstimateReport report(std::int64_t sender_stamp_ns, double cpu_s) const;
  [[nodiscard]] estimators::Estimate estimate() const { return estimator_->estimate(); }
  [[nodiscard]] AgentId id() const { return setup_.id; }
  [[nodiscard]] std::int64_t steps_run() const { return local_step_; }
  [[nodiscard]] const std::map<AgentId, LinkCounters>& links() const { return links_; }
  [[nodiscard]] const std::array<std::uint32_t, kRejectReasonCount>& rejected_by_reason() const {
    return rejected_by_reason_;
  }
  [[nodiscard]] std::int64_t newest_batch_step() const { return newest_batch_step_; }

 private:
  std::optional<RejectReason> check_state(const Header& header, const estimators::StateMessage& message,
                                          bool well_formed) const;
  void reject(LinkCounters* link, RejectReason reason);
  /// Keeps at most one range per neighbour (unknown peer, repeated peer, non-finite, negative or absurd
  /// ranges and std are dropped), drops a fix or motion input that is non-finite, absurd or has a
  /// non-PSD covariance. The generator makes one range per neighbour, so honest batches are unchanged;
  /// this bounds the estimator's work (IEKF solves an M x M system) and keeps NaN/Inf out of estimates.
  void sanitize_batch(estimators::MeasurementBatch& batch);
  [[nodiscard]] std::int64_t world_stamp_ns(std::int64_t world_step) const;

  std::unique_ptr<estimators::Estimator> estimator_;
  estimators::AgentSetup setup_;
  std::set<AgentId> neighbours_;
  AgentRuntimeParams params_;
  core::LinkLossModel loss_;

  std::int64_t local_step_ = 0;
  std::uint32_t next_seq_ = 0;
  std::uint32_t samples_published_ = 0;
  /// Newest state per neighbour; sender_step holds (receiver's step at receipt − 1), so the estimator's
  /// staleness rule measures age in the receiver's own steps (clocks and step counters of different
  /// agents are not comparable: they start at different times and drift).
  std::map<AgentId, estimators::Received<estimators::StateMessage>> states_;
  std::map<AgentId, std::uint32_t> newest_state_seq_;
  std::optional<estimators::MeasurementBatch> pending_batch_;
  std::int64_t newest_batch_step_ = -1;
  double batch_period_s_ = 0.0;
  std::map<AgentId, LinkCounters> links_;
  std::array<std::uint32_t, kRejectReasonCount> rejected_by_reason_{};
};

}  // namespace swarmloc::sim
