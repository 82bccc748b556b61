// Run health and liveness bookkeeping (docs/robustness.md): the verdict from synthetic figures, and
// which agents count as current when reports stop, processes die and faults are scheduled.
#include <gtest/gtest.h>

#include <cmath>

#include "swarmloc/runtime/liveness.hpp"
#include "swarmloc/runtime/run_health.hpp"

namespace swarmloc::runtime {
namespace {

AgentHealth ticks(std::uint32_t total, std::uint32_t late) {
  AgentHealth health;
  health.ticks = total;
  health.late_ticks = late;
  return health;
}

RunHealthInput quiet_run() {
  RunHealthInput input;
  input.rate_hz = 10.0;
  input.world_steps = 300;
  input.world_steps_s = 30.0;
  input.agents = {ticks(300, 0), ticks(300, 1), ticks(300, 0)};
  return input;
}

TEST(RunHealth, AQuietRunIsHealthy) {
  const auto health = assess_health(quiet_run());
  EXPECT_TRUE(health.healthy);
  EXPECT_TRUE(health.reasons.empty());
  EXPECT_EQ(to_json(health)["verdict"], "healthy");
  EXPECT_DOUBLE_EQ(health.figures["late_tick_fraction"].get<double>(), 1.0 / 900.0);
}

TEST(RunHealth, MoreThanFivePercentLateTicksIsStarvation) {
  auto input = quiet_run();
  input.agents = {ticks(300, 15), ticks(300, 15), ticks(300, 15)};  // exactly 5 %: still healthy
  EXPECT_TRUE(assess_health(input).healthy);
  input.agents[0].late_ticks = 16;
  const auto health = assess_health(input);
  ASSERT_FALSE(health.healthy);
  ASSERT_EQ(health.reasons.size(), 1U);
  EXPECT_NE(health.reasons[0].find("CPU-starved"), std::string::npos) << health.reasons[0];
  EXPECT_EQ(to_json(health)["verdict"], "degraded");
}

TEST(RunHealth, ASlowWorldOrLateOrchestratorIsDegraded) {
  auto slow = quiet_run();
  slow.world_steps_s = 300.0 / (0.94 * 10.0);
  EXPECT_FALSE(assess_health(slow).healthy);
  slow.world_steps_s = 300.0 / (0.96 * 10.0);
  EXPECT_TRUE(assess_health(slow).healthy);
  auto late = quiet_run();
  late.late_world_steps = 16;  // of 300
  EXPECT_FALSE(assess_health(late).healthy);
}

TEST(RunHealth, DeathsStallsAndLockstepTimeoutsDegradeEveryMode) {
  for (const bool free_run : {true, false}) {
    auto input = quiet_run();
    input.free_run = free_run;
    input.unscheduled_deaths = 1;
    EXPECT_FALSE(assess_health(input).healthy);
    input.unscheduled_deaths = 0;
    input.stalls = 1;
    EXPECT_FALSE(assess_health(input).healthy);
    input.stalls = 0;
    input.lockstep_timeouts = 2;
    EXPECT_FALSE(assess_health(input).healthy);
  }
}

TEST(RunHealth, LockstepHasNoScheduleToMiss) {
  auto input = quiet_run();
  input.free_run = false;
  input.world_steps_s = 300.0;  // 1 Hz against 10 Hz: lockstep runs as fast as the slowest agent
  input.agents = {ticks(300, 300)};
  EXPECT_TRUE(assess_health(input).healthy);
}

TEST(HealthMeter, CountsLateTicksMissedPeriodsAndAges) {
  HealthMeter meter(0.1);
  meter.on_tick(0.001, 0);
  meter.on_tick(0.049, 0);
  meter.on_tick(0.051, 0);  // more than half a period
  meter.on_tick(0.35, 3);
  meter.on_batch(false);
  meter.on_batch(true);
  meter.on_batch_used(0.12);
  meter.on_neighbour_age(0.1);
  meter.on_neighbour_age(0.3);
  const auto& f = meter.figures();
  EXPECT_EQ(f.ticks, 4U);
  EXPECT_EQ(f.late_ticks, 2U);
  EXPECT_EQ(f.missed_ticks, 3U);
  EXPECT_DOUBLE_EQ(f.max_tick_lateness_s, 0.35);
  EXPECT_NEAR(f.mean_tick_lateness_s, (0.001 + 0.049 + 0.051 + 0.35) / 4.0, 1e-12);
  EXPECT_EQ(f.batches_received, 2U);
  EXPECT_EQ(f.batches_merged, 1U);
  EXPECT_DOUBLE_EQ(f.max_batch_wait_s, 0.12);
  EXPECT_DOUBLE_EQ(f.neighbour_age_mean_s, 0.2);
  EXPECT_DOUBLE_EQ(f.neighbour_age_max_s, 0.3);
}

LivenessLimits free_run_limits() {
  LivenessLimits limits;
  limits.current_s = 0.3;
  limits.stall_s = 2.0;
  limits.restart_grace_s = 10.0;
  return limits;
}

TEST(Liveness, AnEstimateOlderThanTheLimitIsNotCurrent) {
  LivenessTracker tracker(2, free_run_limits());
  EXPECT_FALSE(tracker.current(0, 0.0)) << "never heard";
  tracker.heard(0, 0, 1.0);
  EXPECT_TRUE(tracker.current(0, 1.29));
  EXPECT_FALSE(tracker.current(0, 1.31));
  EXPECT_FALSE(tracker.current(7, 1.0)) << "unknown id";
}

TEST(Liveness, SilenceBeyondTheStallLimitIsAStallUntilTheAgentSpeaksAgain) {
  LivenessTracker tracker(3, free_run_limits());
  for (AgentId i = 0; i < 3; ++i) tracker.heard(i, 0, 0.0);
  tracker.heard(0, 10, 1.0);
  tracker.heard(2, 10, 1.0);
  tracker.check(19, 2.0);
  EXPECT_EQ(tracker.stalls(), 0) << "2.0 s is the limit, not past it";
  tracker.check(21, 2.1);
  EXPECT_EQ(tracker.stalls(), 1);
  EXPECT_EQ(tracker.lost_count(), 1);
  ASSERT_EQ(tracker.events().size(), 1U);
  EXPECT_EQ(tracker.events()[0].agent, 1);
  EXPECT_EQ(tracker.events()[0].kind, LivenessEvent::Kind::kStalled);
  EXPECT_EQ(tracker.events()[0].step, 21);
  tracker.check(22, 2.2);
  EXPECT_EQ(tracker.stalls(), 1) << "one stall, not one per step";
  tracker.heard(1, 60, 6.0);
  EXPECT_EQ(tracker.lost_count(), 0);
  EXPECT_TRUE(tracker.current(1, 6.0));
  EXPECT_EQ(tracker.events().back().kind, LivenessEvent::Kind::kResumed);
  EXPECT_EQ(tracker.fate(1).status, "stalled");
  EXPECT_EQ(tracker.fate(1).step, 21);
  EXPECT_EQ(tracker.fate(0).status, "ok");
}

TEST(Liveness, ADeadAgentStaysUnscoredEvenIfALateSampleArrives) {
  LivenessTracker tracker(2, free_run_limits());
  tracker.heard(0, 0, 0.0);
  tracker.exited(0, 5, 0.5, 128 + 9);
  EXPECT_EQ(tracker.deaths(), 1);
  tracker.heard(0, 5, 0.55);
  EXPECT_FALSE(tracker.current(0, 0.55));
  EXPECT_EQ(tracker.fate(0).status, "died");
  EXPECT_NE(tracker.fate(0).reason.find("signal 9"), std::string::npos) << tracker.fate(0).reason;
  const auto json = tracker.to_json();
  EXPECT_EQ(json["unscheduled_deaths"], 1);
  EXPECT_EQ(json["events"][0]["event"], "died");
}

// Agents say hello until the orchestrator has it, then wait silently for START: the stall limit runs
// from START, not from the hello.
TEST(Liveness, SilenceBetweenTheHelloAndStartIsNotAStall) {
  LivenessTracker tracker(2, free_run_limits());
  tracker.heard(0, 0, 1.0);  // hellos
  tracker.heard(1, 0, 1.0);
  tracker.started(9.0);
  tracker.heard(1, 0, 9.1);
  tracker.check(0, 9.2);
  EXPECT_EQ(tracker.stalls(), 0) << "8 s since agent 0's hello, 0.2 s since START";
  tracker.check(20, 11.1);
  EXPECT_EQ(tracker.stalls(), 1) << "2.1 s after START without a report";
  EXPECT_EQ(tracker.events().at(0).agent, 0);
}

TEST(Liveness, ScheduledFaultsAreExpectedSilence) {
  LivenessTracker tracker(2, free_run_limits());
  tracker.heard(0, 0, 0.0);
  tracker.heard(1, 0, 0.0);
  tracker.scheduled_down(0);  // faults.pause
  tracker.heard(1, 50, 5.0);
  tracker.check(50, 5.0);
  EXPECT_EQ(tracker.stalls(), 0);
  EXPECT_FALSE(tracker.current(0, 5.0));
  tracker.scheduled_up(0, 5.0, false);  // resumed: the stall limit from now
  tracker.heard(1, 60, 6.9);
  tracker.check(60, 6.9);
  EXPECT_EQ(tracker.stalls(), 0);
  tracker.check(61, 7.1);
  EXPECT_EQ(tracker.stalls(), 1) << "resumed but silent past the stall limit";

  LivenessTracker restarted(1, free_run_limits());
  restarted.heard(0, 0, 0.0);
  restarted.scheduled_down(0);  // faults.kill
  restarted.scheduled_up(0, 3.0, true);
  restarted.check(80, 12.9);
  EXPECT_EQ(restarted.stalls(), 0) << "a restart has the start-up grace";
  EXPECT_FALSE(restarted.current(0, 3.0)) << "the killed process's estimate is not the new one's";
  restarted.check(81, 13.1);
  EXPECT_EQ(restarted.stalls(), 1);
}

// Every agent expected up at the end is scored or stalled, however much of its grace or stall limit is left.
TEST(Liveness, AnAgentUnscoredAtTheEndIsStalledWhenTheRunCloses) {
  LivenessTracker tracker(3, free_run_limits());
  for (AgentId i = 0; i < 3; ++i) tracker.heard(i, 0, 0.0);
  tracker.scheduled_down(0);
  tracker.scheduled_down(1);
  tracker.scheduled_up(0, 27.0, true);  // restarted, never heard again
  tracker.scheduled_up(1, 27.0, true);  // restarted and heard
  tracker.heard(1, 298, 29.8);
  tracker.heard(2, 299, 29.9);
  tracker.close(299, 29.9, 30.0, {true, true, true});
  EXPECT_EQ(tracker.stalls(), 1) << "3 s into a 10 s grace, but the run is over";
  ASSERT_EQ(tracker.events().size(), 1U);
  EXPECT_EQ(tracker.events()[0].agent, 0);
  EXPECT_NE(tracker.events()[0].reason.find("not heard"), std::string::npos) << tracker.events()[0].reason;
  EXPECT_EQ(tracker.fate(0).status, "stalled");
  EXPECT_EQ(tracker.fate(1).status, "ok");

  LivenessTracker down(1, free_run_limits());
  down.heard(0, 0, 0.0);
  down.scheduled_down(0);  // killed and not restarted: expected silence to the end
  down.close(299, 29.9, 30.0, {false});
  EXPECT_EQ(down.stalls(), 0);

  LivenessTracker hello(1, free_run_limits());
  hello.heard(0, 0, 0.0);
  hello.scheduled_down(0);
  hello.scheduled_up(0, 29.8, true);
  hello.heard(0, 0, 29.9);  // the new process's hello: alive, but no step run, nothing to score
  hello.close(299, 29.9, 30.0, {false});
  EXPECT_EQ(hello.stalls(), 1);
  EXPECT_NE(hello.events().at(0).reason.find("no step run"), std::string::npos) << hello.events()[0].reason;

  LivenessTracker stale(2, free_run_limits());
  stale.heard(0, 290, 29.0);  // a hang 0.9 s before the last step: short of the 2 s stall limit
  stale.heard(1, 299, 30.5);  // reported during the settle: current
  stale.close(299, 29.9, 30.6, {true, true});
  EXPECT_EQ(stale.stalls(), 1);
  EXPECT_EQ(stale.events().at(0).agent, 0);
  EXPECT_NE(stale.events()[0].reason.find("older than the last step"), std::string::npos)
      << stale.events()[0].reason;
}

TEST(RunHealth, NonFiniteEstimatesMakeTheResultsInvalid) {
  auto input = quiet_run();
  input.free_run = false;  // lockstep or in-process: no schedule to miss, still no NaN allowed
  input.non_finite_steps = 1;
  const auto health = assess_health(input);
  ASSERT_FALSE(health.healthy);
  ASSERT_EQ(health.reasons.size(), 1U);
  EXPECT_NE(health.reasons[0].find("non-finite"), std::string::npos) << health.reasons[0];
  EXPECT_EQ(health.figures["non_finite_steps"], 1);
}

TEST(Liveness, DescribesExits) {
  EXPECT_EQ(describe_exit(1), "exit status 1");
  EXPECT_NE(describe_exit(137).find("signal 9"), std::string::npos);
}

}  // namespace
}  // namespace swarmloc::runtime
