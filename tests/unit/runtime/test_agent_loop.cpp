// The agent loop (runtime/agent_loop.hpp) in one process, with a fake port and a fake clock: when it
// steps in free run and lockstep, what it holds back, when it reports, and when it gives the
// orchestrator up. No DDS: the DDS agent and the simulator drive this same class.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "swarmloc/runtime/agent_loop.hpp"

namespace swarmloc::runtime {
namespace {

/// Publishes its step count and remembers, at each step, which step each state it was handed belongs to
/// (its sender writes the step into the mean).
class CountingEstimator final : public estimators::Estimator {
 public:
  explicit CountingEstimator(std::vector<std::vector<std::int64_t>>* seen) : seen_(seen) {}
  [[nodiscard]] std::string_view name() const override { return "counting"; }
  [[nodiscard]] estimators::Outbox initial_outbox() const override { return state_outbox(); }
  estimators::StepOutput step(const estimators::StepInput& input) override {
    std::vector<std::int64_t> sender_steps;
    for (const auto& received : input.inbox->states)
      sender_steps.push_back(std::llround(received.message.mean_m.x()));
    seen_->push_back(sender_steps);
    ++steps_;
    return {state_outbox(), {}};
  }
  [[nodiscard]] estimators::Estimate estimate() const override { return {}; }

 private:
  [[nodiscard]] estimators::Outbox state_outbox() const {
    estimators::Outbox out;
    estimators::StateMessage state;
    state.mean_m = Vec2(1.0, 2.0);
    state.covariance = Mat2::Identity();
    state.degree = static_cast<std::uint16_t>(steps_);
    out.state = state;
    return out;
  }
  std::vector<std::vector<std::int64_t>>* seen_;
  std::int64_t steps_ = 0;
};

class FakePort final : public AgentPort {
 public:
  void publish(const AgentRuntime::Publication& publication) override { published.push_back(publication); }
  void flush() override { ++flushes; }
  void report(const EstimateReport& report) override { reports.push_back(report); }

  std::vector<AgentRuntime::Publication> published;
  std::vector<EstimateReport> reports;
  int flushes = 0;
};

struct LoopUnderTest {
  explicit LoopUnderTest(const LoopSettings& settings) {
    estimators::AgentSetup setup{settings.id, false, Vec2(5.0, 5.0)};
    AgentRuntimeParams params;
    params.absurd_position_bound_m = 1e5;
    params.world_period_s = settings.world_period_s;
    loop = std::make_unique<AgentLoop>(
        AgentRuntime(std::make_unique<CountingEstimator>(&seen), setup, {1, 2}, params), settings, port);
  }
  std::vector<std::vector<std::int64_t>> seen;
  FakePort port;
  std::unique_ptr<AgentLoop> loop;
};

LoopSettings free_run(double drift_ppm = 0.0, double phase = 0.0) {
  LoopSettings settings;
  settings.id = 0;
  settings.clock.drift_ppm = drift_ppm;
  settings.world_period_s = 0.1;
  settings.phase_fraction = phase;
  return settings;
}

estimators::MeasurementBatch batch_of(std::int64_t world_step) {
  estimators::MeasurementBatch batch;
  batch.world_step = world_step;
  return batch;
}

InboundSample state_from(AgentId sender, std::int64_t step, std::uint32_t seq) {
  estimators::StateMessage state;
  state.mean_m = Vec2(static_cast<double>(step), 0.0);  // the step it belongs to, for the estimator to see
  state.covariance = Mat2::Identity();
  return InboundSample{Header{sender, seq, step, 0, 0}, state, true};
}

TEST(AgentLoop, FreeRunTicksAtItsPhasePlusWholePeriodsOfItsOwnClock) {
  const double drift_ppm = 200.0;
  LoopUnderTest agent(free_run(drift_ppm, 0.25));
  AgentLoop& loop = *agent.loop;
  const double start = 100.0;
  loop.start(start);
  const double tick = 0.1 / (1.0 + drift_ppm * 1e-6);
  for (int m = 1; m <= 5; ++m) {
    const double due = start + (0.25 + m) * tick;
    EXPECT_NEAR(loop.next_due_s(), due, 1e-12);
    EXPECT_EQ(loop.advance(due - 1e-6), 0) << "tick " << m << " comes no earlier than its time";
    EXPECT_EQ(loop.advance(due), 1) << "tick " << m;
  }
  EXPECT_EQ(loop.runtime().steps_run(), 5);
  EXPECT_EQ(agent.port.published.size(), 5U);
  EXPECT_EQ(loop.health().figures().late_ticks, 0U);
}

TEST(AgentLoop, ALateTickStepsOnceAndSkipsTheTicksItMissedWithoutMovingItsPhase) {
  LoopUnderTest agent(free_run(0.0, 0.5));
  AgentLoop& loop = *agent.loop;
  loop.start(0.0);
  // Stopped for 4.2 periods after tick 1 was due (at 0.15 s).
  EXPECT_EQ(loop.advance(0.15 + 0.42), 1);
  EXPECT_EQ(loop.advance(0.15 + 0.42), 0) << "no burst to catch up";
  EXPECT_EQ(loop.health().figures().missed_ticks, 4U);
  EXPECT_EQ(loop.health().figures().late_ticks, 1U);
  EXPECT_NEAR(loop.next_due_s(), 0.65, 1e-12) << "the timer keeps its phase (tick 6 at 0.65 s)";
}

TEST(AgentLoop, NothingRunsBeforeStart) {
  LoopUnderTest agent(free_run());
  EXPECT_EQ(agent.loop->advance(10.0), 0);
  EXPECT_TRUE(std::isinf(agent.loop->next_due_s()));
  EXPECT_FALSE(agent.loop->orchestrator_silent(1000.0));
}

TEST(AgentLoop, LockstepStepsOncePerBatchOnTheSamplesOfEarlierStepsOnly) {
  LoopSettings settings = free_run();
  settings.lockstep = true;
  LoopUnderTest agent(settings);
  AgentLoop& loop = *agent.loop;
  loop.start(0.0);
  EXPECT_EQ(loop.advance(1.0), 0) << "no batch, no step, whatever the time";
  // Neighbour 1 already ran steps 0 and 1; neighbour 2 sends its prior (step -1).
  loop.on_sample(state_from(1, 0, 0), 0.01);
  loop.on_sample(state_from(1, 1, 1), 0.02);
  loop.on_sample(state_from(2, -1, 0), 0.03);
  loop.on_batch(Header{kOrchestratorId, 0, 0, 0, 0}, batch_of(0), 0.04);
  EXPECT_EQ(loop.advance(0.05), 1);
  ASSERT_EQ(agent.seen.size(), 1U);
  EXPECT_EQ(agent.seen[0], std::vector<std::int64_t>{-1}) << "step 0 sees only samples published before it";
  EXPECT_EQ(loop.held_samples(), 2U);
  EXPECT_EQ(agent.port.flushes, 1) << "a lockstep step's samples are with the neighbours before its report";
  loop.on_batch(Header{kOrchestratorId, 1, 1, 0, 0}, batch_of(1), 0.14);
  EXPECT_EQ(loop.advance(0.15), 1);
  EXPECT_EQ(agent.seen[1], (std::vector<std::int64_t>{0, -1})) << "step 1 sees neighbour 1's step 0";
  EXPECT_EQ(loop.held_samples(), 1U);
  EXPECT_EQ(loop.advance(0.2), 0) << "one step per batch";
}

TEST(AgentLoop, FreeRunHandsSamplesToTheRuntimeAtOnce) {
  LoopUnderTest agent(free_run());
  AgentLoop& loop = *agent.loop;
  loop.start(0.0);
  loop.on_sample(state_from(1, 7, 0), 0.01);
  EXPECT_EQ(loop.held_samples(), 0U);
  EXPECT_EQ(loop.advance(0.1), 1);
  EXPECT_EQ(agent.seen[0], std::vector<std::int64_t>{7});
}

TEST(AgentLoop, ReportsOncePerWorldPeriod) {
  LoopSettings settings = free_run();
  settings.steps_per_world_step = 3;
  LoopUnderTest agent(settings);
  AgentLoop& loop = *agent.loop;
  loop.start(0.0);
  for (int m = 1; m <= 9; ++m) loop.advance(loop.next_due_s());
  EXPECT_EQ(agent.port.published.size(), 9U);
  ASSERT_EQ(agent.port.reports.size(), 3U);
  EXPECT_EQ(agent.port.reports.back().steps_run, 9U);
  EXPECT_EQ(agent.port.reports.back().health.ticks, 9U);
}

TEST(AgentLoop, APausedAgentLetsItsTicksPassWithoutAStep) {
  LoopUnderTest agent(free_run());
  AgentLoop& loop = *agent.loop;
  loop.start(0.0);
  loop.set_paused(true);
  for (int m = 1; m <= 3; ++m) EXPECT_EQ(loop.advance(loop.next_due_s()), 0);
  loop.set_paused(false);
  EXPECT_NEAR(loop.next_due_s(), 0.4, 1e-12);
  EXPECT_EQ(loop.advance(loop.next_due_s()), 1);
}

TEST(AgentLoop, TheOrchestratorIsGoneAfterFiftyQuietPeriodsButTheAgentsOwnPauseDoesNotCount) {
  LoopSettings settings = free_run();
  settings.world_period_s = 0.2;  // limit max(5 s, 50 periods) = 10 s
  LoopUnderTest agent(settings);
  AgentLoop& loop = *agent.loop;
  loop.start(0.0);
  loop.on_batch(Header{kOrchestratorId, 0, 0, 0, 0}, batch_of(0), 1.0);
  for (double t = 1.5; t < 10.9; t += 0.5) EXPECT_FALSE(loop.orchestrator_silent(t)) << t;
  EXPECT_TRUE(loop.orchestrator_silent(11.1));

  LoopUnderTest stopped(settings);
  stopped.loop->start(0.0);
  stopped.loop->on_batch(Header{kOrchestratorId, 0, 0, 0, 0}, batch_of(0), 1.0);
  EXPECT_FALSE(stopped.loop->orchestrator_silent(2.0));
  // SIGSTOP for 30 s: on waking, the orchestrator has had no chance to speak yet; it has 10 s from then.
  for (double t = 32.0; t < 40.9; t += 0.5) EXPECT_FALSE(stopped.loop->orchestrator_silent(t)) << t;
  EXPECT_TRUE(stopped.loop->orchestrator_silent(41.5));
}

TEST(AgentLoop, LockstepAllowsTheStartupTimeoutBeforeGivingUp) {
  LoopSettings settings = free_run();
  settings.lockstep = true;
  settings.startup_timeout_s = 60.0;
  LoopUnderTest agent(settings);
  agent.loop->start(0.0);
  for (double t = 0.5; t < 59.9; t += 0.5) EXPECT_FALSE(agent.loop->orchestrator_silent(t)) << t;
  EXPECT_TRUE(agent.loop->orchestrator_silent(60.5));
}

TEST(AgentLoop, ASensorOnlyAgentSaysHelloEveryHalfSecondAndNeverSteps) {
  LoopSettings settings = free_run();
  settings.sensor_only = true;
  LoopUnderTest agent(settings);
  AgentLoop& loop = *agent.loop;
  loop.start(0.0);
  for (int k = 0; k <= 40; ++k) EXPECT_EQ(loop.advance(k * 0.05), 0);
  EXPECT_EQ(agent.port.reports.size(), 5U);  // at 0, 0.5, 1.0, 1.5, 2.0 s
  EXPECT_TRUE(agent.port.published.empty());
  EXPECT_EQ(loop.runtime().steps_run(), 0);
}

TEST(AgentLoop, AnnouncingPublishesThePriorAsStepMinusOne) {
  LoopUnderTest agent(free_run());
  agent.loop->announce(0.0);
  ASSERT_EQ(agent.port.published.size(), 1U);
  EXPECT_EQ(agent.port.published[0].header.step, -1);
  ASSERT_TRUE(agent.port.published[0].outbox.state.has_value());
}

}  // namespace
}  // namespace swarmloc::runtime
