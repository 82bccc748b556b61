// AgentRuntime: the shared mailbox / loss / validation logic of both runtimes.
#include <gtest/gtest.h>

#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/runtime/agent_runtime.hpp"

namespace swarmloc::runtime {
namespace {

AgentRuntime make_runtime(double loss = 0.0) {
  estimators::AgentSetup setup{0, false, Vec2(5.0, 5.0)};
  AgentRuntimeParams params;
  params.seed = 42;
  params.loss.loss_probability = loss;
  params.absurd_position_bound_m = 1e5;
  return AgentRuntime(config::make_estimator("ieif", setup, {}), setup, {1, 2, 3}, params);
}

estimators::StateMessage anchor_state(const Vec2& position) {
  estimators::StateMessage m;
  m.mean_m = position;
  m.covariance = Mat2::Zero();
  m.anchor = true;
  return m;
}

Header header_from(AgentId sender, std::uint32_t seq) { return Header{sender, seq, 0, 0, 0}; }

TEST(AgentRuntime, RejectsNanAndNonPsdStatesAndKeepsRunning) {
  auto runtime = make_runtime();
  auto nan_state = anchor_state(Vec2(0.0, 0.0));
  nan_state.mean_m.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(runtime.on_state(header_from(1, 0), nan_state));
  auto non_psd = anchor_state(Vec2(0.0, 10.0));
  non_psd.covariance << 1.0, 5.0, 5.0, 1.0;
  EXPECT_FALSE(runtime.on_state(header_from(2, 0), non_psd));
  auto asymmetric = anchor_state(Vec2(0.0, 10.0));
  asymmetric.covariance << 1.0, 0.5, -0.5, 1.0;
  EXPECT_FALSE(runtime.on_state(header_from(2, 1), asymmetric));
  auto absurd = anchor_state(Vec2(1e9, 0.0));
  EXPECT_FALSE(runtime.on_state(header_from(3, 0), absurd));
  EXPECT_FALSE(runtime.on_state(header_from(7, 0), anchor_state(Vec2(1.0, 1.0))));  // not a neighbour

  const auto& reasons = runtime.rejected_by_reason();
  EXPECT_EQ(reasons[static_cast<std::size_t>(RejectReason::kNonFinite)], 1U);
  EXPECT_EQ(reasons[static_cast<std::size_t>(RejectReason::kNotSymmetricPsd)], 2U);
  EXPECT_EQ(reasons[static_cast<std::size_t>(RejectReason::kAbsurdMagnitude)], 1U);
  EXPECT_EQ(reasons[static_cast<std::size_t>(RejectReason::kUnknownSender)], 1U);

  // Still steps, and the estimate stays finite: nothing hostile reached the estimator.
  estimators::MeasurementBatch batch;
  batch.world_step = 0;
  batch.ranges = {{1, 5.0, 0.1}, {2, 5.0, 0.1}};
  runtime.on_batch(Header{}, batch);
  runtime.step(0);
  EXPECT_TRUE(runtime.estimate().mean_m.allFinite());
  EXPECT_EQ(runtime.steps_run(), 1);
}

TEST(AgentRuntime, RejectsEachImplausibleCavityForItsReason) {
  // make_runtime: positions beyond 1e5 m and variances beyond 1e14 m² are absurd.
  auto good = anchor_state(Vec2(1.0, 2.0));
  good.cavities = {{0, Vec2(0.5, -0.25), 0.0, 0.04}, {2, Vec2(-6e4, 8e4), 0.0, 1e14}};
  struct Case {
    const char* name;
    RejectReason reason;
    void (*spoil)(estimators::StateMessage&);
  };
  constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const Case cases[] = {
      {"65 cavities", RejectReason::kAbsurdMagnitude,
       [](estimators::StateMessage& m) {
         const auto first = m.cavities[0];
         m.cavities.resize(65, first);
       }},
      {"NaN offset x", RejectReason::kNonFinite,
       [](estimators::StateMessage& m) { m.cavities[1].offset_m.x() = kNan; }},
      {"-Inf offset y", RejectReason::kNonFinite,
       [](estimators::StateMessage& m) { m.cavities[0].offset_m.y() = -kInf; }},
      {"+Inf offset z", RejectReason::kNonFinite,
       [](estimators::StateMessage& m) { m.cavities[1].offset_z_m = kInf; }},
      {"NaN variance", RejectReason::kNonFinite,
       [](estimators::StateMessage& m) { m.cavities[0].variance_m2 = kNan; }},
      {"negative variance", RejectReason::kAbsurdMagnitude,
       [](estimators::StateMessage& m) { m.cavities[0].variance_m2 = -1e-300; }},
      {"variance beyond the bound", RejectReason::kAbsurdMagnitude,
       [](estimators::StateMessage& m) { m.cavities[1].variance_m2 = 1.0000001e14; }},
      {"planar offset beyond the bound", RejectReason::kAbsurdMagnitude,
       [](estimators::StateMessage& m) { m.cavities[1].offset_m.y() = 8.0001e4; }},
      // |(x, y)| is exactly the bound; with z the offset is beyond it.
      {"offset with z beyond the bound", RejectReason::kAbsurdMagnitude,
       [](estimators::StateMessage& m) { m.cavities[1].offset_z_m = 1.0; }},
  };
  auto runtime = make_runtime();
  std::uint32_t seq = 0;
  ASSERT_TRUE(runtime.on_state(header_from(1, seq++), good)) << "at the bounds, a cavity is plausible";
  std::array<std::uint32_t, kRejectReasonCount> expected{};
  for (const auto& c : cases) {
    auto hostile = good;
    c.spoil(hostile);
    EXPECT_FALSE(runtime.on_state(header_from(1, seq++), hostile)) << c.name;
    ++expected[static_cast<std::size_t>(c.reason)];
    EXPECT_EQ(runtime.rejected_by_reason(), expected) << c.name;
  }
  EXPECT_TRUE(runtime.on_state(header_from(1, seq), good));
}

TEST(AgentRuntime, DropsDuplicateAndReorderedSamples) {
  auto runtime = make_runtime();
  EXPECT_TRUE(runtime.on_state(header_from(1, 5), anchor_state(Vec2(0.0, 0.0))));
  EXPECT_FALSE(runtime.on_state(header_from(1, 5), anchor_state(Vec2(0.0, 0.0))));
  EXPECT_FALSE(runtime.on_state(header_from(1, 4), anchor_state(Vec2(0.0, 0.0))));
  EXPECT_TRUE(runtime.on_state(header_from(1, 6), anchor_state(Vec2(0.0, 0.0))));
  const auto& reasons = runtime.rejected_by_reason();
  EXPECT_EQ(reasons[static_cast<std::size_t>(RejectReason::kDuplicate)], 1U);
  EXPECT_EQ(reasons[static_cast<std::size_t>(RejectReason::kReordered)], 1U);
  const auto links = runtime.links();  // by value: counters span restarts
  const auto& link = links.at(1);
  EXPECT_EQ(link.arrived, 4U);
  EXPECT_EQ(link.delivered, 2U);
  EXPECT_EQ(link.sent(), 3U);  // seqs 4..6
}

/// Remembers, at each step, the sender and mean x of every state it was handed, in the inbox's order.
class InboxRecorder final : public estimators::Estimator {
 public:
  using Seen = std::vector<std::pair<AgentId, double>>;
  explicit InboxRecorder(std::vector<Seen>* steps) : steps_(steps) {}
  [[nodiscard]] std::string_view name() const override { return "inbox_recorder"; }
  [[nodiscard]] estimators::Outbox initial_outbox() const override { return {}; }
  estimators::StepOutput step(const estimators::StepInput& input) override {
    Seen seen;
    for (const auto& received : input.inbox->states)
      seen.emplace_back(received.sender, received.message.mean_m.x());
    steps_->push_back(seen);
    return {};
  }
  [[nodiscard]] estimators::Estimate estimate() const override { return {}; }

 private:
  std::vector<Seen>* steps_;
};

TEST(AgentRuntime, EachStepSeesEveryNeighboursNewestSampleInSenderOrder) {
  std::vector<InboxRecorder::Seen> steps;
  estimators::AgentSetup setup{0, false, Vec2(5.0, 5.0)};
  AgentRuntimeParams params;
  params.absurd_position_bound_m = 1e5;
  AgentRuntime runtime(std::make_unique<InboxRecorder>(&steps), setup, {1, 2, 3}, params);
  const auto send = [&](AgentId sender, std::uint32_t seq, double x) {
    return runtime.on_state(header_from(sender, seq), anchor_state(Vec2(x, 0.0)));
  };
  ASSERT_TRUE(send(3, 0, 30.0));
  runtime.step(0);
  ASSERT_TRUE(send(1, 0, 10.0));
  runtime.step(0);
  ASSERT_TRUE(send(3, 1, 31.0));  // replaces 3's sample where it is
  runtime.step(0);
  ASSERT_TRUE(send(2, 0, 20.0));   // goes between 1 and 3
  EXPECT_FALSE(send(2, 0, 99.0));  // a duplicate changes nothing
  runtime.step(0);
  runtime.step(0);  // nothing new: the same newest samples again
  using Seen = InboxRecorder::Seen;
  ASSERT_EQ(steps.size(), 5U);
  EXPECT_EQ(steps[0], (Seen{{3, 30.0}}));
  EXPECT_EQ(steps[1], (Seen{{1, 10.0}, {3, 30.0}}));
  EXPECT_EQ(steps[2], (Seen{{1, 10.0}, {3, 31.0}}));
  EXPECT_EQ(steps[3], (Seen{{1, 10.0}, {2, 20.0}, {3, 31.0}}));
  EXPECT_EQ(steps[4], steps[3]);
}

TEST(AgentRuntime, InjectedLossDropsTheConfiguredFraction) {
  auto runtime = make_runtime(0.3);
  constexpr std::uint32_t kSamples = 20000;
  for (std::uint32_t seq = 0; seq < kSamples; ++seq)
    runtime.on_state(header_from(1, seq), anchor_state(Vec2(0.0, 0.0)));
  const auto links = runtime.links();  // by value: counters span restarts
  const auto& link = links.at(1);
  EXPECT_EQ(link.arrived, kSamples);
  EXPECT_EQ(link.delivered + link.dropped_injected, kSamples);
  const double sigma = std::sqrt(kSamples * 0.3 * 0.7);
  EXPECT_NEAR(static_cast<double>(link.dropped_injected), 0.3 * kSamples, 4.0 * sigma);
}

TEST(AgentRuntime, SameSeedDropsTheSameSamples) {
  auto a = make_runtime(0.5);
  auto b = make_runtime(0.5);
  for (std::uint32_t seq = 0; seq < 500; ++seq) {
    EXPECT_EQ(a.on_state(header_from(2, seq), anchor_state(Vec2(0.0, 0.0))),
              b.on_state(header_from(2, seq), anchor_state(Vec2(0.0, 0.0))));
  }
}

TEST(AgentRuntime, BatchEntriesNoSensorCouldProduceAreDroppedAndCounted) {
  // Found by the batch fuzz target: 20 000 ranges in one batch made the IEKF solve a 20 000 x 20 000
  // system, and non-finite entries could reach the estimate. One range per neighbour survives.
  auto runtime = make_runtime();
  for (AgentId j = 1; j <= 3; ++j) runtime.on_state(header_from(j, 0), anchor_state(Vec2(10.0 * j, 0.0)));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  estimators::MeasurementBatch batch;
  batch.world_step = 0;
  batch.ranges = {{1, 5.0, 0.1},  {1, 6.0, 0.1}, {7, 5.0, 0.1},  {2, nan, 0.1},
                  {2, -1.0, 0.1}, {2, 1e9, 0.1}, {3, 5.0, -0.1}, {3, 8.0, 0.1}};
  for (int k = 0; k < 10000; ++k) batch.ranges.push_back({2, 5.0, 0.1});
  batch.fix =
      estimators::AbsoluteFix{Vec2(1.0, 1.0), (Mat2() << 1.0, 2.0, 2.0, 1.0).finished(), std::nullopt};
  batch.motion = estimators::MotionInput{Vec2(nan, 0.0), 0.1, Mat2::Zero()};
  runtime.on_batch(Header{}, batch);
  const auto& reasons = runtime.rejected_by_reason();
  EXPECT_EQ(reasons[static_cast<std::size_t>(RejectReason::kUnknownSender)], 1U);
  EXPECT_EQ(reasons[static_cast<std::size_t>(RejectReason::kNonFinite)], 2U);        // NaN range, motion
  EXPECT_EQ(reasons[static_cast<std::size_t>(RejectReason::kAbsurdMagnitude)], 3U);  // -1, 1e9, std < 0
  EXPECT_EQ(reasons[static_cast<std::size_t>(RejectReason::kDuplicate)], 1U + 9999U);
  EXPECT_EQ(reasons[static_cast<std::size_t>(RejectReason::kNotSymmetricPsd)], 1U);  // the fix
  const auto out = runtime.step(0);
  EXPECT_TRUE(runtime.estimate().mean_m.allFinite());
  (void)out;
}

}  // namespace
}  // namespace swarmloc::runtime
