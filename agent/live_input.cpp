#include "live_input.hpp"

#include <algorithm>
#include <cmath>

namespace swarmloc::agent {
namespace {

/// Accepted messages remembered for the duplicate check: a copy arriving this many messages late is
/// still recognized (older ones are dropped as reordered anyway).
constexpr std::size_t kLiveRecentMessages = 64;

}  // namespace

bool LiveStreamGate::seen_recently(std::int64_t stamp_ns, std::int64_t counter) const {
  return std::find(recent_.begin(), recent_.end(), std::make_pair(counter, stamp_ns)) != recent_.end();
}

void LiveStreamGate::accept(std::int64_t stamp_ns, std::int64_t counter, double arrival_s) {
  any_ = true;
  silent_ = false;
  last_stamp_ns_ = stamp_ns;
  last_counter_ = counter;
  last_arrival_s_ = arrival_s;
  recent_.emplace_back(counter, stamp_ns);
  if (recent_.size() > kLiveRecentMessages) recent_.pop_front();
  ++counters_.accepted;
}

LiveStreamGate::Verdict LiveStreamGate::admit(std::int64_t stamp_ns, std::int64_t counter, double arrival_s) {
  if (!any_) {
    accept(stamp_ns, counter, arrival_s);
    return Verdict::kAccept;
  }
  poll(arrival_s);  // a silence is counted even if no loop turn saw it pass
  if (seen_recently(stamp_ns, counter)) {
    ++counters_.duplicates;
    return Verdict::kDuplicate;
  }
  const bool has_counter = counter >= 0 && last_counter_ >= 0;
  // How far the stamp is from where the arrivals say the robot's clock should be now.
  const double stamp_step_s = 1e-9 * static_cast<double>(stamp_ns - last_stamp_ns_);
  const double off_s = stamp_step_s - (arrival_s - last_arrival_s_);
  if (has_counter && counter < last_counter_) {
    // An older counter: late or out of order, unless the stamps moved on (the driver restarted).
    if (stamp_step_s <= 0.0) {
      ++counters_.reordered;
      return Verdict::kReordered;
    }
    ++counters_.restarts;
  } else if (std::abs(off_s) > limits_.clock_jump_s) {
    ++counters_.clock_jumps;  // the new stamps are the clock from now on
  } else if (stamp_step_s <= 0.0) {
    ++counters_.reordered;
    return Verdict::kReordered;
  }
  accept(stamp_ns, counter, arrival_s);
  return Verdict::kAccept;
}

void LiveStreamGate::poll(double now_s) {
  if (any_ && !silent_ && now_s - last_arrival_s_ > limits_.silence_s) {
    silent_ = true;
    ++counters_.silences;
  }
}

std::int64_t LiveStreamGate::robot_now_ns(double now_s) const {
  if (!any_) return 0;
  return last_stamp_ns_ + static_cast<std::int64_t>(std::llround((now_s - last_arrival_s_) * 1e9));
}

std::string to_string(const LiveStreamCounters& c) {
  return "accepted " + std::to_string(c.accepted) + " duplicates " + std::to_string(c.duplicates) +
         " reordered " + std::to_string(c.reordered) + " clock_jumps " + std::to_string(c.clock_jumps) +
         " silences " + std::to_string(c.silences) + " restarts " + std::to_string(c.restarts);
}

}  // namespace swarmloc::agent
