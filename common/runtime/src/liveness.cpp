#include "swarmloc/runtime/liveness.hpp"

#include <algorithm>
#include <cstdio>
#include <cstring>

namespace swarmloc::runtime {

const char* to_string(LivenessEvent::Kind kind) {
  switch (kind) {
    case LivenessEvent::Kind::kDied:
      return "died";
    case LivenessEvent::Kind::kStalled:
      return "stalled";
    case LivenessEvent::Kind::kResumed:
      return "resumed";
  }
  return "?";
}

std::string describe_exit(int exit_status) {
  if (exit_status > 128 && exit_status < 128 + 65) {
    const int signal = exit_status - 128;
    return "killed by signal " + std::to_string(signal) + " (" + strsignal(signal) + ")";
  }
  return "exit status " + std::to_string(exit_status);
}

LivenessTracker::LivenessTracker(int agents, LivenessLimits limits)
    : limits_(limits), agents_(static_cast<std::size_t>(std::max(0, agents))) {}

void LivenessTracker::record(AgentId agent, LivenessEvent::Kind kind, std::int64_t step, double now_s,
                             std::string reason) {
  events_.push_back(LivenessEvent{agent, kind, step, now_s, std::move(reason)});
}

void LivenessTracker::heard(AgentId agent, std::int64_t step, double now_s) {
  if (agent < 0 || static_cast<std::size_t>(agent) >= agents_.size()) return;
  auto& a = agents_[static_cast<std::size_t>(agent)];
  if (a.state == State::kDead || a.state == State::kDown) return;  // a late sample of the old process
  if (a.state == State::kStalled) {
    const double silent_s = a.last_heard_s ? now_s - *a.last_heard_s : 0.0;
    a.state = State::kAlive;
    char reason[96];
    std::snprintf(reason, sizeof reason, "an estimate again after %.1f s of silence", silent_s);
    record(agent, LivenessEvent::Kind::kResumed, step, now_s, reason);
  }
  a.last_heard_s = now_s;
}

void LivenessTracker::exited(AgentId agent, std::int64_t step, double now_s, int exit_status) {
  if (agent < 0 || static_cast<std::size_t>(agent) >= agents_.size()) return;
  auto& a = agents_[static_cast<std::size_t>(agent)];
  if (a.state == State::kDead) return;
  a.state = State::kDead;
  ++deaths_;
  record(agent, LivenessEvent::Kind::kDied, step, now_s, "process ended: " + describe_exit(exit_status));
}

void LivenessTracker::scheduled_down(AgentId agent) {
  if (agent < 0 || static_cast<std::size_t>(agent) >= agents_.size()) return;
  agents_[static_cast<std::size_t>(agent)].state = State::kDown;
}

void LivenessTracker::scheduled_up(AgentId agent, double now_s, bool restarted) {
  if (agent < 0 || static_cast<std::size_t>(agent) >= agents_.size()) return;
  auto& a = agents_[static_cast<std::size_t>(agent)];
  a.state = State::kAlive;
  a.silent_since_s = now_s;
  a.allowance_s = restarted ? limits_.restart_grace_s : limits_.stall_s;
  if (restarted) a.last_heard_s.reset();  // the old process's estimates are not the new one's
}

void LivenessTracker::started(double now_s) {
  for (auto& a : agents_) {
    if (a.state != State::kAlive) continue;
    a.silent_since_s = std::max(a.silent_since_s, now_s);
    a.allowance_s = std::max(a.allowance_s, limits_.stall_s);
  }
}

void LivenessTracker::check(std::int64_t step, double now_s) {
  for (std::size_t i = 0; i < agents_.size(); ++i) {
    auto& a = agents_[i];
    if (a.state != State::kAlive) continue;
    // Silence is measured from the newest report, or from the last scheduled restart / resume.
    const double since_s = std::max(a.last_heard_s.value_or(a.silent_since_s), a.silent_since_s);
    const double allowed_s = a.last_heard_s && *a.last_heard_s >= a.silent_since_s
                                 ? limits_.stall_s
                                 : std::max(limits_.stall_s, a.allowance_s);
    if (!a.last_heard_s && a.allowance_s == 0.0) continue;  // never heard and not expected yet (start-up)
    if (now_s - since_s > allowed_s) {
      a.state = State::kStalled;
      ++stalls_;
      char reason[96];
      std::snprintf(reason, sizeof reason, "no estimate for %.1f s (limit %.1f s)", now_s - since_s,
                    allowed_s);
      record(static_cast<AgentId>(i), LivenessEvent::Kind::kStalled, step, now_s, reason);
    }
  }
}

void LivenessTracker::close(std::int64_t step, double judged_s, double now_s,
                            const std::vector<bool>& has_estimate) {
  check(step, now_s);
  for (std::size_t i = 0; i < agents_.size(); ++i) {
    auto& a = agents_[i];
    if (a.state != State::kAlive) continue;
    const bool heard = a.last_heard_s && *a.last_heard_s >= a.silent_since_s;
    const bool stepped = i < has_estimate.size() && has_estimate[i];
    if (stepped && current(static_cast<AgentId>(i), judged_s)) continue;  // scored at the last step
    char reason[160];
    if (heard && stepped) {
      std::snprintf(
          reason, sizeof reason,
          "unscored at the end: its newest estimate is %.2f s older than the last step (limit %.2f s)",
          judged_s - *a.last_heard_s, limits_.current_s);
    } else {
      std::snprintf(reason, sizeof reason,
                    "unscored at the end: %s since it was started, restarted or resumed %.1f s before",
                    heard ? "no step run" : "not heard", now_s - a.silent_since_s);
    }
    a.state = State::kStalled;
    ++stalls_;
    record(static_cast<AgentId>(i), LivenessEvent::Kind::kStalled, step, now_s, reason);
  }
}

bool LivenessTracker::current(AgentId agent, double now_s) const {
  if (agent < 0 || static_cast<std::size_t>(agent) >= agents_.size()) return false;
  const auto& a = agents_[static_cast<std::size_t>(agent)];
  return a.state == State::kAlive && a.last_heard_s && now_s - *a.last_heard_s <= limits_.current_s;
}

int LivenessTracker::lost_count() const {
  int lost = 0;
  for (const auto& a : agents_) lost += (a.state == State::kDead || a.state == State::kStalled) ? 1 : 0;
  return lost;
}

LivenessTracker::Fate LivenessTracker::fate(AgentId agent) const {
  Fate fate;
  for (const auto& event : events_) {
    if (event.agent != agent || event.kind == LivenessEvent::Kind::kResumed) continue;
    fate.status = to_string(event.kind);
    fate.step = event.step;
    fate.reason = event.reason;
  }
  return fate;
}

nlohmann::json LivenessTracker::to_json() const {
  nlohmann::json events = nlohmann::json::array();
  for (const auto& e : events_) {
    events.push_back({{"agent", e.agent},
                      {"event", to_string(e.kind)},
                      {"step", e.step},
                      {"time_s", e.time_s},
                      {"reason", e.reason}});
  }
  return {{"unscheduled_deaths", deaths_}, {"stalls", stalls_}, {"events", events}};
}

}  // namespace swarmloc::runtime
