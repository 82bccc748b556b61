// Chi-square innovation gating of range updates (IEIF, IEKF; KalmanFilterParams::range_gate_chi2).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "eigen_gtest.hpp"
#include "named_estimators.hpp"
#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/kalman/kernels.hpp"

namespace swarmloc::estimators {
namespace {

// Agent 0 at (10, 10) with four anchors at the corners of a 20 m square, exact ranges declared with
// sigma 0.1 m. The agent converges for 30 steps, then one step brings the range to anchor 1 with +50 m.
const Vec2 kTruth(10.0, 10.0);
const std::array<Vec2, 4> kAnchors{Vec2(0.0, 0.0), Vec2(20.0, 0.0), Vec2(0.0, 20.0), Vec2(20.0, 20.0)};

struct Outcome {
  double moved_m = 0.0;  ///< |x after the outlier step − x before|
  double error_before_m = 0.0;
  StepDiagnostics diagnostics;
};

Outcome outlier_step(const std::string& algorithm, double gate, int update_iterations = 1) {
  AgentSetup setup;
  setup.id = 0;
  setup.initial_guess_m = Vec2(12.0, 8.5);
  KalmanFilterParams params;
  params.range_gate_chi2 = gate;
  params.initial_std_m = 3.0;
  params.update_iterations = update_iterations;
  const auto estimator = testing::make_named_estimator(algorithm, setup, params);
  Inbox inbox;
  for (AgentId j = 1; j <= 4; ++j) {
    Received<StateMessage> anchor;
    anchor.sender = j;
    anchor.sender_step = -1;
    anchor.message.anchor = true;
    anchor.message.mean_m = kAnchors[static_cast<std::size_t>(j - 1)];
    anchor.message.covariance = Mat2::Zero();
    inbox.states.push_back(anchor);
  }
  const auto batch_at = [&](std::int64_t step, double outlier_m) {
    MeasurementBatch batch;
    batch.world_step = step;
    for (AgentId j = 1; j <= 4; ++j) {
      const double range = (kTruth - kAnchors[static_cast<std::size_t>(j - 1)]).norm();
      batch.ranges.push_back(RangeMeasurement{j, range + (j == 1 ? outlier_m : 0.0), 0.1});
    }
    return batch;
  };
  constexpr std::int64_t kConverge = 30;
  for (std::int64_t k = 0; k < kConverge; ++k) {
    const auto batch = batch_at(k, 0.0);
    for (auto& state : inbox.states) state.sender_step = k - 1;
    const auto out = estimator->step(StepInput{k, &batch, &inbox});
    EXPECT_EQ(out.diagnostics.ranges_gated, 0) << algorithm << ": a good range was gated at step " << k;
  }
  Outcome outcome;
  const Vec2 before = estimator->estimate().mean_m;
  outcome.error_before_m = (before - kTruth).norm();
  const auto batch = batch_at(kConverge, 50.0);
  for (auto& state : inbox.states) state.sender_step = kConverge - 1;
  outcome.diagnostics = estimator->step(StepInput{kConverge, &batch, &inbox}).diagnostics;
  outcome.moved_m = (estimator->estimate().mean_m - before).norm();
  return outcome;
}

TEST(RangeGate, OneOutlierRangeOfFiftyMetresIsGatedAndDoesNotMoveTheEstimate) {
  for (const std::string algorithm : {"ieif", "iekf"}) {
    SCOPED_TRACE(algorithm);
    const Outcome gated = outlier_step(algorithm, 9.0);
    const Outcome open = outlier_step(algorithm, 0.0);
    ASSERT_LT(gated.error_before_m, 0.01) << "did not converge before the outlier";
    // With the gate the three exact ranges agree with the estimate: it stays where it was.
    EXPECT_LT(gated.moved_m, 0.01) << "moved " << gated.moved_m << " m";
    EXPECT_EQ(gated.diagnostics.ranges_gated, 1);
    EXPECT_EQ(gated.diagnostics.neighbours_used, 3);
    // Without it the outlier pulls the estimate by metres.
    EXPECT_GT(open.moved_m, 1.0) << "moved " << open.moved_m << " m";
    EXPECT_EQ(open.diagnostics.ranges_gated, 0);
    EXPECT_EQ(open.diagnostics.neighbours_used, 4);
    std::printf("[ gate ] %s: outlier +50 m moves the estimate %.3g m with gate 9, %.3g m without\n",
                algorithm.c_str(), gated.moved_m, open.moved_m);
  }
}

// The iterated IEIF update linearizes again only the ranges the gate kept: from a prior 1 m off, with one
// range 50 m long, it lands where the three good ranges alone put it.
TEST(RangeGate, TheIteratedUpdateKeepsAGatedRangeOut) {
  const Vec2 x_pred(10.6, 9.2);
  const Mat2 Psi_pred = 4.0 * Mat2::Identity();  // prior std 0.5 m: the 1 m error passes a gate of 9
  std::vector<RangeLink> links;
  for (AgentId j = 1; j <= 4; ++j) {
    const Vec2& at = kAnchors[static_cast<std::size_t>(j - 1)];
    links.push_back(RangeLink{j, at, Mat2::Zero(), (kTruth - at).norm() + (j == 1 ? 50.0 : 0.0), 0.1});
  }
  const auto iterated = [&](const std::vector<RangeLink>& used, double gate) {
    Linearization rows = linearize_ranges(x_pred, used);
    gate_ranges(rows, Psi_pred.inverse(), gate);
    return iterated_information_update(x_pred, Psi_pred, used, rows,
                                       information_update(x_pred, Psi_pred, rows), 10);
  };
  const std::vector<RangeLink> good(links.begin() + 1, links.end());
  const InformationUpdate gated = iterated(links, 9.0);
  const InformationUpdate without_outlier = iterated(good, 0.0);
  EXPECT_MATRIX_NEAR(gated.mean, without_outlier.mean, 1e-12);
  EXPECT_LT((gated.mean - kTruth).norm(), 0.05);  // 0.02 m: the prior, 1 m off with std 0.5 m, pulls it
  EXPECT_GT((iterated(links, 0.0).mean - kTruth).norm(), 1.0) << "ungated, the outlier pulls it away";
}

TEST(RangeGate, GateDropsRowsWhoseNormalizedInnovationExceedsTheThreshold) {
  Linearization rows;
  rows.jacobian.resize(5, 2);
  rows.jacobian << 1.0, 0.0, 0.0, 1.0, 0.6, 0.8, 0.8, 0.6, -0.6, 0.8;
  rows.innovation.resize(5);
  rows.innovation << 0.29, 0.31, -5.0, 0.1, 0.05;
  rows.variance = VecX::Constant(5, 0.01);
  // s = r + u P uᵀ = 0.01 with P = 0: ν²/s = 8.41, 9.61, 2500, 1, 0.25 against a gate of 9.
  Linearization copy = rows;
  EXPECT_EQ(gate_ranges(copy, Mat2::Zero(), 9.0), 2);
  ASSERT_EQ(copy.jacobian.rows(), 3);
  EXPECT_DOUBLE_EQ(copy.innovation(0), 0.29);
  EXPECT_DOUBLE_EQ(copy.innovation(1), 0.1);
  // The receiver's own covariance widens the gate: P = I gives s = 1.01, only the last (24.8) is out.
  copy = rows;
  EXPECT_EQ(gate_ranges(copy, Mat2::Identity(), 9.0), 1);
  EXPECT_EQ(copy.jacobian.rows(), 4);
  // Most rows outside the gate: the prediction is off, not the ranges; nothing is dropped.
  copy = rows;
  copy.innovation = VecX::Constant(5, 1.0);
  copy.innovation(0) = 0.0;
  copy.innovation(1) = 0.0;
  EXPECT_EQ(gate_ranges(copy, Mat2::Zero(), 9.0), 0);
  EXPECT_EQ(copy.jacobian.rows(), 5);
  // Gate 0 or a non-finite covariance: no gating.
  copy = rows;
  EXPECT_EQ(gate_ranges(copy, Mat2::Zero(), 0.0), 0);
  EXPECT_EQ(gate_ranges(copy, Mat2::Constant(std::nan("")), 9.0), 0);
  EXPECT_EQ(copy.jacobian.rows(), 5);
}

}  // namespace
}  // namespace swarmloc::estimators
