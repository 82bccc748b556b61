#pragma once
// In-process synchronous message bus for the reproduction experiments (ALGORITHMS.md §1.5): every agent has a
// mailbox with the newest message per neighbour and family; a round delivers what every agent published in
// the previous round. Internal to the experiments.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <random>
#include <utility>
#include <vector>

#include "swarmloc/estimators/estimator.hpp"

namespace swarmloc::sim::experiments::detail {

using Adjacency = std::vector<std::vector<int>>;

class SyncBus {
 public:
  explicit SyncBus(Adjacency adjacency) : adjacency_(std::move(adjacency)), mailboxes_(adjacency_.size()) {}

  /// Delivers `outbox` of `sender` (published at `sender_step`) into every neighbour's mailbox.
  void deliver(int sender, std::int64_t sender_step, const estimators::Outbox& outbox) {
    for (const int receiver : adjacency_[static_cast<std::size_t>(sender)]) {
      estimators::Inbox& box = mailboxes_[static_cast<std::size_t>(receiver)];
      if (outbox.state) put(box.states, sender, sender_step, *outbox.state);
      if (outbox.information) put(box.information, sender, sender_step, *outbox.information);
      if (!outbox.consensus.empty()) put(box.consensus, sender, sender_step, outbox.consensus.back());
      if (outbox.belief) put(box.beliefs, sender, sender_step, *outbox.belief);
    }
  }
  [[nodiscard]] const estimators::Inbox& inbox(int agent) const {
    return mailboxes_[static_cast<std::size_t>(agent)];
  }

  /// One synchronous round: every agent steps on the mailbox of the previous round, then all outboxes
  /// are delivered. `batches[i]` may be nullptr. With `awake`, only agents with awake[i] step and publish
  /// (the others are not running yet: their mailbox fills, they send nothing).
  void round(std::vector<std::unique_ptr<estimators::Estimator>>& agents, std::int64_t step,
             const std::vector<const estimators::MeasurementBatch*>& batches,
             const std::vector<bool>* awake = nullptr) {
    std::vector<estimators::Outbox> outboxes(agents.size());
    for (std::size_t i = 0; i < agents.size(); ++i) {
      if (awake != nullptr && !(*awake)[i]) continue;
      const estimators::StepInput input{step, batches.empty() ? nullptr : batches[i], &mailboxes_[i]};
      outboxes[i] = agents[i]->step(input).outbox;
    }
    for (std::size_t i = 0; i < agents.size(); ++i) {
      if (awake != nullptr && !(*awake)[i]) continue;
      deliver(static_cast<int>(i), step, outboxes[i]);
    }
  }
  void publish_initial(const std::vector<std::unique_ptr<estimators::Estimator>>& agents) {
    for (std::size_t i = 0; i < agents.size(); ++i)
      deliver(static_cast<int>(i), -1, agents[i]->initial_outbox());
  }

 private:
  template <typename Message>
  static void put(std::vector<estimators::Received<Message>>& list, int sender, std::int64_t step,
                  const Message& message) {
    for (auto& entry : list) {
      if (entry.sender == sender) {
        entry.sender_step = step;
        entry.message = message;
        return;
      }
    }
    list.push_back(estimators::Received<Message>{sender, step, message});
  }

  Adjacency adjacency_;
  std::vector<estimators::Inbox> mailboxes_;
};

/// True if the undirected graph is connected (BFS).
inline bool connected(const Adjacency& adjacency) {
  if (adjacency.empty()) return true;
  std::vector<bool> seen(adjacency.size(), false);
  std::vector<int> queue{0};
  seen[0] = true;
  std::size_t count = 1;
  while (!queue.empty()) {
    const int v = queue.back();
    queue.pop_back();
    for (const int w : adjacency[static_cast<std::size_t>(v)]) {
      if (!seen[static_cast<std::size_t>(w)]) {
        seen[static_cast<std::size_t>(w)] = true;
        ++count;
        queue.push_back(w);
      }
    }
  }
  return count == adjacency.size();
}

}  // namespace swarmloc::sim::experiments::detail
