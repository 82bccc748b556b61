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
#include <vector>

#include "swarmloc/core/link_model.hpp"
#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/runtime/envelope.hpp"

namespace swarmloc::runtime {

struct AgentRuntimeParams {
  std::uint64_t seed = 1;
  core::LinkLossParams loss;
  double absurd_position_bound_m = 1e6;  ///< |mean| beyond this is rejected
  double absurd_variance_m2 = 1e14;      ///< covariance entries beyond this are rejected
  /// faults.partition: during world steps [partition_from, partition_to] samples between agents of
  /// different partition_group are dropped (counted as injected drops). Empty groups: no partition.
  std::vector<std::uint8_t> partition_group;
  std::int64_t partition_from = 0;
  std::int64_t partition_to = -1;
  double world_period_s = 0.1;  ///< 1 / run.rate_hz: turns a sample's world stamp into its world step
  /// First sample number. A restarted agent (faults.kill) starts a new range, so its neighbours'
  /// duplicate/reorder checks accept its samples: incarnation k starts at k · 2^24.
  std::uint32_t first_seq = 0;
};

class AgentRuntime {
 public:
  AgentRuntime(std::unique_ptr<estimators::Estimator> estimator, estimators::AgentSetup setup,
               std::vector<AgentId> neighbours, const AgentRuntimeParams& params);

  /// An inter-agent sample arrived. Applies loss, validation and ordering rules; returns true if it
  /// entered the mailbox (the newest sample per sender and family).
  bool on_state(const Header& header, const estimators::StateMessage& message, bool well_formed = true);
  bool on_information(const Header& header, const estimators::InformationMessage& message,
                      bool well_formed = true);
  bool on_consensus(const Header& header, const estimators::ConsensusMessage& message,
                    bool well_formed = true);
  bool on_belief(const Header& header, const estimators::BeliefMessage& message, bool well_formed = true);
  bool on_observations(const Header& header, const estimators::ObservationMessage& message,
                       bool well_formed = true);
  /// Routes one sample of any family to the matching on_* (for drivers that hold typed samples).
  bool on_sample(const Header& header, const estimators::StateMessage& m, bool well_formed = true) {
    return on_state(header, m, well_formed);
  }
  bool on_sample(const Header& header, const estimators::InformationMessage& m, bool well_formed = true) {
    return on_information(header, m, well_formed);
  }
  bool on_sample(const Header& header, const estimators::ConsensusMessage& m, bool well_formed = true) {
    return on_consensus(header, m, well_formed);
  }
  bool on_sample(const Header& header, const estimators::BeliefMessage& m, bool well_formed = true) {
    return on_belief(header, m, well_formed);
  }
  bool on_sample(const Header& header, const estimators::ObservationMessage& m, bool well_formed = true) {
    return on_observations(header, m, well_formed);
  }
  /// A measurement batch arrived (batches are not subject to injected loss: they model the sensor).
  /// Entries that cannot come from a real sensor are removed and counted by reason (see sanitize_batch).
  void on_batch(const Header& header, estimators::MeasurementBatch batch);

  /// Runs one local step with the newest data. Returns the messages to publish. Every sample an agent
  /// writes takes the next number of one counter, in the order state, information, consensus…, belief,
  /// observations;
  /// `header.seq` is the first of them (for_each_sample hands out each sample's own header).
  struct Publication {
    Header header;
    estimators::Outbox outbox;
  };
  /// Calls visit(header, message) for every sample of `publication` in seq order.
  template <typename Visitor>
  static void for_each_sample(const Publication& publication, Visitor&& visit) {
    Header header = publication.header;
    const auto& out = publication.outbox;
    if (out.state) visit(header, *out.state), ++header.seq;
    if (out.information) visit(header, *out.information), ++header.seq;
    for (const auto& consensus : out.consensus) visit(header, consensus), ++header.seq;
    if (out.belief) visit(header, *out.belief), ++header.seq;
    if (out.observations) visit(header, *out.observations), ++header.seq;
  }
  Publication step(std::int64_t sender_stamp_ns);
  /// The message published before the first step (header.step = −1).
  Publication initial_publication(std::int64_t sender_stamp_ns);

  [[nodiscard]] EstimateReport report(std::int64_t sender_stamp_ns, double cpu_s) const;
  [[nodiscard]] estimators::Estimate estimate() const { return estimator_->estimate(); }
  [[nodiscard]] AgentId id() const { return setup_.id; }
  /// The agent's neighbours, sorted.
  [[nodiscard]] const std::vector<AgentId>& neighbours() const { return neighbours_; }
  [[nodiscard]] std::int64_t steps_run() const { return local_step_; }
  [[nodiscard]] std::uint32_t samples_published() const { return samples_published_; }
  /// Samples written in a step (header.step >= 0), i.e. not the initial announcement(s).
  [[nodiscard]] std::uint32_t samples_published_in_steps() const { return samples_published_in_steps_; }
  /// Per-sender counters; sent() spans the sender's restarts (faults.kill).
  [[nodiscard]] std::map<AgentId, LinkCounters> links() const;
  [[nodiscard]] const std::array<std::uint32_t, kRejectReasonCount>& rejected_by_reason() const {
    return rejected_by_reason_;
  }
  [[nodiscard]] std::int64_t newest_batch_step() const { return newest_batch_step_; }
  /// True if a measurement batch arrived that no step has consumed yet.
  [[nodiscard]] bool has_pending_batch() const { return pending_batch_.has_value(); }

 private:
  /// Where the newest sample per neighbour of one family is kept, and the seq it came with
  /// (ordering/duplicates), indexed by the neighbour's slot (its position in neighbours_). The samples
  /// themselves live in the inbox the estimator steps on (inbox_), in slot order, so a step copies none.
  /// Flat arrays, not maps: at 10^4 agents the simulator spent most of a step walking per-agent trees
  /// (docs/scale.md).
  template <typename Message>
  struct Mailbox {
    std::vector<std::uint32_t> newest_seq;
    std::vector<int> index;  ///< the slot's sample in the inbox's vector; −1: none yet
  };
  /// The slot of neighbour `id` (its index in neighbours_), or −1 if `id` is not a neighbour.
  [[nodiscard]] int slot_of(AgentId id) const;
  template <typename Message>
  void init_mailbox(Mailbox<Message>& mailbox) const;
  /// Stores an accepted sample and returns it; nullptr if dropped or rejected.
  template <typename Message>
  estimators::Received<Message>* on_sample(core::TopicFamily family, Mailbox<Message>& mailbox,
                                           std::vector<estimators::Received<Message>>& newest,
                                           const Header& header, const Message& message, bool well_formed);
  [[nodiscard]] std::optional<RejectReason> check_content(const estimators::StateMessage& m) const;
  [[nodiscard]] std::optional<RejectReason> check_content(const estimators::InformationMessage& m) const;
  [[nodiscard]] std::optional<RejectReason> check_content(const estimators::ConsensusMessage& m) const;
  [[nodiscard]] std::optional<RejectReason> check_content(const estimators::BeliefMessage& m) const;
  [[nodiscard]] std::optional<RejectReason> check_content(const estimators::ObservationMessage& m) const;
  Publication publish(estimators::Outbox outbox, std::int64_t step, std::int64_t sender_stamp_ns,
                      std::int64_t world_stamp_ns);
  void reject(LinkCounters* link, RejectReason reason);
  /// Keeps at most one range per neighbour (unknown peer, repeated peer, non-finite, negative or absurd
  /// ranges and std are dropped), drops a fix or motion input that is non-finite, absurd or has a
  /// non-PSD covariance. The generator makes one range per neighbour, so honest batches are unchanged;
  /// this bounds the estimator's work (IEKF solves an M x M system) and keeps NaN/Inf out of estimates.
  void sanitize_batch(estimators::MeasurementBatch& batch);
  static void carry_over(const estimators::MeasurementBatch& superseded, estimators::MeasurementBatch& batch);
  [[nodiscard]] std::int64_t world_stamp_ns(std::int64_t world_step) const;
  /// faults.partition: true if `header`'s sender is on the other side while the sample's world step
  /// (the step of the batch the sender had used) lies in the window — the same answer in every runtime.
  [[nodiscard]] bool partitioned(const Header& header) const;

  std::unique_ptr<estimators::Estimator> estimator_;
  estimators::AgentSetup setup_;
  std::vector<AgentId> neighbours_;  ///< sorted; a neighbour's index here is its slot
  AgentRuntimeParams params_;
  core::LinkLossModel loss_;

  std::int64_t local_step_ = 0;
  std::uint32_t next_seq_ = 0;
  std::uint32_t samples_published_ = 0;
  std::uint32_t samples_published_in_steps_ = 0;
  /// Newest state per neighbour; sender_step holds (receiver's step at receipt − 1), so the estimator's
  /// staleness rule measures age in the receiver's own steps (clocks and step counters of different
  /// agents are not comparable: they start at different times and drift).
  Mailbox<estimators::StateMessage> states_;
  Mailbox<estimators::InformationMessage> information_;
  Mailbox<estimators::ConsensusMessage> consensus_;
  Mailbox<estimators::BeliefMessage> beliefs_;
  Mailbox<estimators::ObservationMessage> observations_;
  /// The newest sample of every neighbour that sent one, per family in slot (= sender id) order: what the
  /// estimator steps on, stored here as the samples arrive.
  estimators::Inbox inbox_;
  std::optional<estimators::MeasurementBatch> pending_batch_;
  std::int64_t newest_batch_step_ = -1;
  double batch_period_s_ = 0.0;
  std::vector<LinkCounters> links_;  ///< per slot; valid where link_seen_
  std::vector<bool> link_seen_;
  std::vector<std::uint32_t> sent_by_earlier_incarnations_;  ///< per slot
  std::array<std::uint32_t, kRejectReasonCount> rejected_by_reason_{};
};

}  // namespace swarmloc::runtime
