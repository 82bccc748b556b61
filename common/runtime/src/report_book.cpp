#include "swarmloc/runtime/report_book.hpp"

#include <algorithm>
#include <utility>

namespace swarmloc::runtime {

ReportBook::ReportBook(int agents)
    : slots_(static_cast<std::size_t>(std::max(0, agents))), killed_(slots_.size(), false) {}

bool ReportBook::take(EstimateReport report) {
  const AgentId agent = report.header.agent_id;
  if (!known(agent) || killed_[static_cast<std::size_t>(agent)]) return false;
  Slot& slot = slots_[static_cast<std::size_t>(agent)];
  if (slot && report.steps_run < slot->steps_run) return false;  // older than what we hold
  slot = std::move(report);
  return true;
}

void ReportBook::killed(AgentId agent) {
  if (!known(agent)) return;
  slots_[static_cast<std::size_t>(agent)].reset();
  killed_[static_cast<std::size_t>(agent)] = true;
}

void ReportBook::restarted(AgentId agent) {
  if (known(agent)) killed_[static_cast<std::size_t>(agent)] = false;
}

}  // namespace swarmloc::runtime
