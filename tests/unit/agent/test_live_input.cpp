// LiveStreamGate (agent/live_input.hpp, docs/robustness.md "Live sensor input"): each fault of a
// driver's stream is counted once, and only faults are.
#include <gtest/gtest.h>

#include "live_input.hpp"

namespace {

using swarmloc::agent::LiveStreamGate;
using Verdict = LiveStreamGate::Verdict;

constexpr std::int64_t kLiveGateBase = 5'000'000'000'000;  // the robot's clock: far from the agent's
constexpr double kLiveGatePeriod = 0.1;

std::int64_t gate_stamp(int step, double extra_s = 0.0) {
  return kLiveGateBase + static_cast<std::int64_t>((step * kLiveGatePeriod + extra_s) * 1e9);
}

/// A driver sending steps [from, to) on time.
void gate_play(LiveStreamGate& gate, int from, int to, double extra_s = 0.0) {
  for (int step = from; step < to; ++step)
    ASSERT_EQ(gate.admit(gate_stamp(step, extra_s), step, 100.0 + step * kLiveGatePeriod), Verdict::kAccept)
        << step;
}

TEST(LiveStreamGate, ACleanStreamCountsNothing) {
  LiveStreamGate gate(swarmloc::config::LiveLimits{});
  gate.poll(1000.0);  // no data yet: nothing to fall silent
  EXPECT_FALSE(gate.has_data());
  gate_play(gate, 0, 100);
  EXPECT_TRUE(gate.has_data());
  const auto& c = gate.counters();
  EXPECT_EQ(c.accepted, 100U);
  EXPECT_EQ(c.duplicates + c.reordered + c.clock_jumps + c.silences + c.restarts, 0U);
}

TEST(LiveStreamGate, ADuplicateIsDroppedAndCounted) {
  LiveStreamGate gate(swarmloc::config::LiveLimits{});
  gate_play(gate, 0, 10);
  EXPECT_EQ(gate.admit(gate_stamp(9), 9, 100.95), Verdict::kDuplicate);
  gate_play(gate, 10, 12);
  EXPECT_EQ(gate.admit(gate_stamp(10), 10, 101.2), Verdict::kDuplicate);  // a late copy too
  EXPECT_EQ(gate.counters().duplicates, 2U);
  EXPECT_EQ(gate.counters().reordered, 0U);
}

TEST(LiveStreamGate, AnOlderMessageIsDroppedAsReordered) {
  LiveStreamGate gate(swarmloc::config::LiveLimits{});
  gate_play(gate, 0, 5);
  EXPECT_EQ(gate.admit(gate_stamp(6), 6, 100.6), Verdict::kAccept);
  EXPECT_EQ(gate.admit(gate_stamp(5), 5, 100.61), Verdict::kReordered);
  EXPECT_EQ(gate.counters().reordered, 1U);
  // Without a counter (odometry) the stamp orders.
  LiveStreamGate odom(swarmloc::config::LiveLimits{});
  EXPECT_EQ(odom.admit(gate_stamp(2), -1, 100.2), Verdict::kAccept);
  EXPECT_EQ(odom.admit(gate_stamp(1), -1, 100.21), Verdict::kReordered);
}

TEST(LiveStreamGate, ASilenceIsCountedOnceAndEndsWithTheNextMessage) {
  LiveStreamGate gate(swarmloc::config::LiveLimits{});
  gate_play(gate, 0, 10);
  gate.poll(100.9 + 0.5);
  EXPECT_FALSE(gate.silent());
  gate.poll(100.9 + 1.5);
  gate.poll(100.9 + 3.0);
  EXPECT_TRUE(gate.silent());
  gate_play(gate, 60, 70);  // 5 s later, the robot's clock ran on: no jump
  EXPECT_FALSE(gate.silent());
  EXPECT_EQ(gate.counters().silences, 1U);
  EXPECT_EQ(gate.counters().clock_jumps, 0U);
}

TEST(LiveStreamGate, AClockJumpEitherWayIsCountedAndFollowed) {
  LiveStreamGate gate(swarmloc::config::LiveLimits{});
  gate_play(gate, 0, 10);
  gate_play(gate, 10, 20, 10.0);  // +10 s from step 10 on
  EXPECT_EQ(gate.counters().clock_jumps, 1U);
  gate_play(gate, 20, 30, -20.0);  // and back 30 s: still newer by its counter
  EXPECT_EQ(gate.counters().clock_jumps, 2U);
  EXPECT_EQ(gate.counters().reordered, 0U);
  EXPECT_EQ(gate.robot_now_ns(100.0 + 29 * kLiveGatePeriod), gate_stamp(29, -20.0));
}

TEST(LiveStreamGate, ARestartedDriverCounterIsARestart) {
  LiveStreamGate gate(swarmloc::config::LiveLimits{});
  gate_play(gate, 0, 10);
  EXPECT_EQ(gate.admit(gate_stamp(10), 0, 101.0), Verdict::kAccept);
  EXPECT_EQ(gate.counters().restarts, 1U);
}

}  // namespace
