#pragma once
// In-process synchronous message bus for the reproduction experiments (docs/algorithms.md §1.5): every agent
// has a mailbox with the newest message per neighbour and family; a round delivers what every agent published
// in the previous round. Internal to the experiments.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <random>
#include <utility>
#include <vector>

#include "swarmloc/estimators/estimator.hpp"

namespace swarmloc::research::detail {

using Adjacency = std::vector<std::vector<int>>;

class SyncBus {
 public:
  explicit SyncBus(Adjacency adjacency) : adjacency_(std::move(adjacency)), mailboxes_(adjacency_.size()) {
    slots_.resize(adjacency_.size());
    for (std::size_t i = 0; i < adjacency_.size(); ++i) slots_[i].resize(adjacency_[i].size());
  }

  /// Delivers `outbox` of `sender` (published at `sender_step`) into every neighbour's mailbox.
  void deliver(int sender, std::int64_t sender_step, const estimators::Outbox& outbox) {
    const auto s = static_cast<std::size_t>(sender);
    const std::vector<int>& receivers = adjacency_[s];
    std::vector<Slots>& slots = slots_[s];
    // One family at a time: the families fill separate lists, so the order of the loops changes nothing.
    if (outbox.state) {
      for (std::size_t k = 0; k < receivers.size(); ++k)
        put(mailbox(receivers[k]).states, slots[k].state, sender, sender_step, *outbox.state);
    }
    if (outbox.information) {
      for (std::size_t k = 0; k < receivers.size(); ++k)
        put(mailbox(receivers[k]).information, slots[k].information, sender, sender_step,
            *outbox.information);
    }
    if (!outbox.consensus.empty()) {
      for (std::size_t k = 0; k < receivers.size(); ++k)
        put(mailbox(receivers[k]).consensus, slots[k].consensus, sender, sender_step,
            outbox.consensus.back());
    }
    if (outbox.belief) {
      for (std::size_t k = 0; k < receivers.size(); ++k)
        put(mailbox(receivers[k]).beliefs, slots[k].belief, sender, sender_step, *outbox.belief);
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
    outboxes_.resize(agents.size());  // reused: the runs have many short rounds
    for (std::size_t i = 0; i < agents.size(); ++i) {
      if (awake != nullptr && !(*awake)[i]) continue;
      const estimators::StepInput input{step, batches.empty() ? nullptr : batches[i], &mailboxes_[i]};
      outboxes_[i] = agents[i]->step(input).outbox;
    }
    for (std::size_t i = 0; i < agents.size(); ++i) {
      if (awake != nullptr && !(*awake)[i]) continue;
      deliver(static_cast<int>(i), step, outboxes_[i]);
    }
  }
  void publish_initial(const std::vector<std::unique_ptr<estimators::Estimator>>& agents) {
    for (std::size_t i = 0; i < agents.size(); ++i)
      deliver(static_cast<int>(i), -1, agents[i]->initial_outbox());
  }

 private:
  /// Where a sender's entries sit in one neighbour's lists, per family (-1: not looked up yet).
  struct Slots {
    int state = -1;
    int information = -1;
    int consensus = -1;
    int belief = -1;
  };

  estimators::Inbox& mailbox(int agent) { return mailboxes_[static_cast<std::size_t>(agent)]; }

  /// Stores `message` as the newest from `sender` in `list`: it replaces the sender's entry, or is appended
  /// if there is none. `slot` remembers the entry's index, so only the first message searches the list
  /// (lists only grow, so the index stays valid).
  template <typename Message>
  static void put(std::vector<estimators::Received<Message>>& list, int& slot, int sender, std::int64_t step,
                  const Message& message) {
    if (slot < 0) {
      const auto it =
          std::find_if(list.begin(), list.end(), [&](const auto& entry) { return entry.sender == sender; });
      if (it == list.end()) {
        list.push_back(estimators::Received<Message>{sender, step, message});
        slot = static_cast<int>(list.size()) - 1;
        return;
      }
      slot = static_cast<int>(it - list.begin());
    }
    auto& entry = list[static_cast<std::size_t>(slot)];
    entry.sender_step = step;
    entry.message = message;
  }

  Adjacency adjacency_;
  std::vector<estimators::Inbox> mailboxes_;
  std::vector<std::vector<Slots>> slots_;  ///< slots_[sender][k]: in the mailbox of adjacency_[sender][k]
  std::vector<estimators::Outbox> outboxes_;
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

}  // namespace swarmloc::research::detail
