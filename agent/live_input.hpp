#pragma once
// What a live agent checks of each sensor stream before the estimator sees it (docs/robustness.md,
// "Live sensor input"): duplicates and out-of-order messages are dropped, a driver that stops and a
// clock that jumps are noticed; each is counted. Stamps are the robot's own clock, arrivals the agent's
// monotonic clock: only their differences are compared, so the two clocks need not agree.
#include <cstdint>
#include <deque>
#include <string>
#include <utility>

#include "swarmloc/config/deployment.hpp"

namespace swarmloc::agent {

struct LiveStreamCounters {
  std::uint64_t accepted = 0;
  std::uint64_t duplicates = 0;   ///< the same message again (same counter and stamp)
  std::uint64_t reordered = 0;    ///< older than one already used (late or out of order): dropped
  std::uint64_t clock_jumps = 0;  ///< stamps moved unlike the arrivals by more than limits.clock_jump_s
  std::uint64_t silences = 0;     ///< the stream stopped for more than limits.silence_s
  std::uint64_t restarts = 0;     ///< the driver's counter started again (stamps moved on)
};

class LiveStreamGate {
 public:
  enum class Verdict { kAccept, kDuplicate, kReordered };

  explicit LiveStreamGate(const config::LiveLimits& limits) : limits_(limits) {}

  /// A message stamped `stamp_ns` (robot clock) with the driver's counter `counter` (−1: the message type
  /// has none) arrived at `arrival_s` (monotonic). Accepted messages go to the estimator.
  Verdict admit(std::int64_t stamp_ns, std::int64_t counter, double arrival_s);
  /// Counts a silence as soon as it passes limits.silence_s (called every loop turn).
  void poll(double now_s);
  /// True from a silence until the next accepted message.
  [[nodiscard]] bool silent() const { return silent_; }
  [[nodiscard]] const LiveStreamCounters& counters() const { return counters_; }
  /// True once a message was accepted.
  [[nodiscard]] bool has_data() const { return any_; }
  /// The robot's clock at `now_s`, from the newest accepted stamp (0 before any).
  [[nodiscard]] std::int64_t robot_now_ns(double now_s) const;

 private:
  bool seen_recently(std::int64_t stamp_ns, std::int64_t counter) const;
  void accept(std::int64_t stamp_ns, std::int64_t counter, double arrival_s);

  config::LiveLimits limits_;
  LiveStreamCounters counters_;
  bool any_ = false;
  bool silent_ = false;
  std::int64_t last_stamp_ns_ = 0;
  std::int64_t last_counter_ = -1;
  double last_arrival_s_ = 0.0;
  std::deque<std::pair<std::int64_t, std::int64_t>> recent_;  ///< (counter, stamp) of the last accepted
};

/// "accepted 200 duplicates 1 …": one line for logs.
std::string to_string(const LiveStreamCounters& counters);

}  // namespace swarmloc::agent
