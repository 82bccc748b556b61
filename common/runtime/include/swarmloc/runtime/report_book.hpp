#pragma once
// The newest estimate report of each agent process, as the orchestrator holds them (docs/robustness.md,
// "Liveness", Restarts). A report replaces the held one only if it is not older; an agent killed by the fault
// schedule holds none, and the reports its dead process still had in flight are dropped, so that its restart,
// whose step count begins again at zero, is not taken for the older one.
#include <cstddef>
#include <optional>
#include <vector>

#include "swarmloc/core/types.hpp"
#include "swarmloc/runtime/envelope.hpp"

namespace swarmloc::runtime {

class ReportBook {
 public:
  using Slot = std::optional<EstimateReport>;

  explicit ReportBook(int agents = 0);

  /// Holds `report` if its agent is known, not killed, and it is not older than the held one.
  bool take(EstimateReport report);
  /// faults.kill: the agent's process is gone; nothing is held for it until restarted().
  void killed(AgentId agent);
  /// faults.kill's restart: the new process's reports are taken from its first step on.
  void restarted(AgentId agent);

  [[nodiscard]] const Slot& operator[](std::size_t agent) const { return slots_[agent]; }
  [[nodiscard]] std::size_t size() const { return slots_.size(); }
  [[nodiscard]] auto begin() const { return slots_.begin(); }
  [[nodiscard]] auto end() const { return slots_.end(); }

 private:
  [[nodiscard]] bool known(AgentId agent) const {
    return agent >= 0 && static_cast<std::size_t>(agent) < slots_.size();
  }

  std::vector<Slot> slots_;
  std::vector<bool> killed_;
};

}  // namespace swarmloc::runtime
