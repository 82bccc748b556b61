#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <random>

#include "eigen_gtest.hpp"
#include "swarmloc/core/gaussian.hpp"
#include "swarmloc/estimators/kalman/ieif.hpp"
#include "swarmloc/estimators/kalman/kernels.hpp"

namespace swarmloc::estimators {
namespace {

Received<StateMessage> state_from(AgentId sender, std::int64_t sender_step, const Vec2& mean, const Mat2& cov,
                                  bool anchor = false) {
  Received<StateMessage> r;
  r.sender = sender;
  r.sender_step = sender_step;
  r.message.mean_m = mean;
  r.message.covariance = cov;
  r.message.anchor = anchor;
  return r;
}

// Node 0 at x̂ = (3, 4) with Ψ_0 = I, Q = I; anchors 1 at (0, 0) and 2 at (6, 0); σ_r = 0.5.
struct HandCase {
  KalmanFilterParams params;
  AgentSetup setup;
  Inbox inbox;
  MeasurementBatch batch;

  HandCase() {
    params.initial_information = 1.0;
    params.process_noise_std_m = 1.0;
    setup.id = 0;
    setup.initial_guess_m = Vec2(3.0, 4.0);
    inbox.states = {state_from(1, -1, Vec2(0.0, 0.0), Mat2::Zero(), true),
                    state_from(2, -1, Vec2(6.0, 0.0), Mat2::Zero(), true)};
    batch.world_step = 0;
    batch.ranges = {RangeMeasurement{1, 5.5, 0.5}, RangeMeasurement{2, 4.5, 0.5}};
  }
  [[nodiscard]] StepInput input() const { return StepInput{0, &batch, &inbox}; }
};

TEST(Ieif, OneStepWithTwoAnchorsMatchesHandArithmetic) {
  const HandCase c;
  // Prediction: Ψ_{0|−1} = (I + I·I)⁻¹ I = 0.5 I, ŷ_{0|−1} = 0.5·(3, 4) = (1.5, 2).
  // Anchor 1: d̂ = ‖(3,4)‖ = 5, u = (0.6, 0.8), ν = 0.5, r̃ = 0.25 (P_j = 0), z' = 0.5 + 5 = 5.5.
  // Anchor 2: d̂ = ‖(−3,4)‖ = 5, u = (−0.6, 0.8), ν = −0.5, r̃ = 0.25, z' = −0.5 + (−1.8 + 3.2) = 0.9.
  // Φ = 4·[uuᵀ₁ + uuᵀ₂] = 4·diag(0.72, 1.28) = diag(2.88, 5.12).
  // ι = 4·[(0.6, 0.8)·5.5 + (−0.6, 0.8)·0.9] = 4·(2.76, 5.12) = (11.04, 20.48).
  // Ψ = diag(3.38, 5.62), ŷ = (12.54, 22.48), x̂ = (12.54/3.38, 22.48/5.62) = (3.7100591716…, 4).
  const Mat2 Phi_expected = Vec2(2.88, 5.12).asDiagonal();
  const Vec2 iota_expected(11.04, 20.48);
  const Mat2 Psi_expected = Vec2(3.38, 5.62).asDiagonal();
  const Vec2 x_expected(12.54 / 3.38, 4.0);

  const Mat2 Psi_pred = predict_information(Mat2::Identity(), Mat2::Identity());
  EXPECT_MATRIX_NEAR(Psi_pred, Mat2(0.5 * Mat2::Identity()), 1e-12);
  const LinkSelection links = collect_range_links(c.input(), 0, c.params);
  ASSERT_EQ(links.links.size(), 2U);
  const Linearization rows = linearize_ranges(Vec2(3.0, 4.0), links.links);
  EXPECT_MATRIX_NEAR(rows.innovation, Eigen::Vector2d(0.5, -0.5), 1e-12);
  EXPECT_MATRIX_NEAR(rows.variance, Eigen::Vector2d(0.25, 0.25), 1e-12);
  const InformationUpdate update = information_update(Vec2(3.0, 4.0), Psi_pred, rows);
  EXPECT_MATRIX_NEAR(update.Phi, Phi_expected, 1e-12);
  EXPECT_MATRIX_NEAR(update.iota, iota_expected, 1e-12);
  EXPECT_MATRIX_NEAR(update.Psi, Psi_expected, 1e-12);
  EXPECT_MATRIX_NEAR(update.y, Vec2(12.54, 22.48), 1e-12);
  EXPECT_MATRIX_NEAR(update.mean, x_expected, 1e-12);

  Ieif ieif(c.setup, c.params);
  const StepOutput out = ieif.step(c.input());
  EXPECT_TRUE(out.diagnostics.updated);
  EXPECT_EQ(out.diagnostics.neighbours_used, 2);
  EXPECT_EQ(out.diagnostics.neighbours_skipped, 0);
  EXPECT_MATRIX_NEAR(ieif.information(), Psi_expected, 1e-12);
  EXPECT_MATRIX_NEAR(ieif.mean(), x_expected, 1e-12);
  // Published: the predicted pair for the next step ([B-5]): P = Ψ⁻¹ + Q.
  ASSERT_TRUE(out.outbox.state.has_value());
  EXPECT_MATRIX_NEAR(out.outbox.state->mean_m, x_expected, 1e-12);
  const Mat2 P_next = Vec2(1.0 / 3.38 + 1.0, 1.0 / 5.62 + 1.0).asDiagonal();
  EXPECT_MATRIX_NEAR(out.outbox.state->covariance, P_next, 1e-12);
  EXPECT_FALSE(out.outbox.state->anchor);
  const Estimate e = ieif.estimate();
  EXPECT_TRUE(e.valid);
  EXPECT_MATRIX_NEAR(e.covariance, Mat2(Vec2(1.0 / 3.38, 1.0 / 5.62).asDiagonal()), 1e-12);
}

/// Exact ranges (declared σ 0.1 m) from an agent at `truth` to three anchors.
struct AnchorFix {
  Inbox inbox;
  MeasurementBatch batch;
  AnchorFix(const Vec2& truth, const std::array<Vec2, 3>& anchors) {
    for (AgentId j = 1; j <= 3; ++j) {
      const Vec2& at = anchors[static_cast<std::size_t>(j - 1)];
      inbox.states.push_back(state_from(j, -1, at, Mat2::Zero(), true));
      batch.ranges.push_back(RangeMeasurement{j, (truth - at).norm(), 0.1});
    }
  }
  /// The position after one IEIF step from `guess` (Ψ_0 = 1e-6 I) with `iterations` update passes.
  [[nodiscard]] Vec2 after_one_step(const Vec2& guess, int iterations) const {
    KalmanFilterParams params;
    params.update_iterations = iterations;
    AgentSetup setup;
    setup.initial_guess_m = guess;
    Ieif node(setup, params);
    node.step(StepInput{0, &batch, &inbox});
    return node.mean();
  }
};

// From the diffuse start (Ψ_0 = 1e-6 I) one linearization at a guess 11 m off lands far from the position the
// exact ranges give; the iterated update (Gauss–Newton with step halving, KalmanFilterParams::
// update_iterations) reaches it. Anchors at three corners of a 20 m square, the agent at (12, 7).
TEST(Ieif, IteratedUpdateFromADiffusePriorReachesTheExactFixWhereOneLinearizationDoesNot) {
  const Vec2 truth(12.0, 7.0);
  const AnchorFix fix(truth, {Vec2(0.0, 0.0), Vec2(20.0, 0.0), Vec2(0.0, 20.0)});
  const Vec2 guess(2.0, 17.0);
  const double once = (fix.after_one_step(guess, 1) - truth).norm();
  const double iterated = (fix.after_one_step(guess, 10) - truth).norm();
  EXPECT_GT(once, 1.0);
  EXPECT_LT(iterated, 1e-4);
  EXPECT_LT((fix.after_one_step(guess, 3) - truth).norm(), once) << "every pass lowers the cost";
  std::printf("[ ieif ] one step from 11 m off: error %.3g m with one linearization, %.3g m iterated\n", once,
              iterated);
}

// Step halving matters: here plain Gauss–Newton passes (each taking its full step) end 1.9 km away; with
// halving every pass lowers the cost and the update reaches the fix. Three clustered anchors, a guess 15 m
// off on the far side (found by a seeded search over random layouts).
TEST(Ieif, IteratedUpdateHalvesStepsThatWouldRaiseTheCost) {
  const Vec2 truth(15.824, 12.944);
  const AnchorFix fix(truth, {Vec2(11.911, 10.844), Vec2(14.906, 10.032), Vec2(10.596, 11.493)});
  EXPECT_LT((fix.after_one_step(Vec2(1.219, 17.901), 10) - truth).norm(), 1e-4);
}

TEST(Ieif, UpdateEqualsPredictionPlusGainTimesInnovation) {
  // x̂_{k|k} = x̂_{k|k−1} + Ψ_{k|k}⁻¹ J_iᵀ R̃⁻¹ ν with uncertain (non-anchor) neighbours
  // (docs/algorithms.md §3.2).
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const Vec2 x_pred(5.0 * normal(rng), 5.0 * normal(rng));
    const Mat2 A = Mat2::Random();
    const Mat2 Psi_pred = A * A.transpose() + 0.1 * Mat2::Identity();
    std::vector<RangeLink> links;
    for (int j = 0; j < 5; ++j) {
      const Mat2 B = 0.3 * Mat2::Random();
      const Vec2 x_j = x_pred + Vec2(6.0 * normal(rng), 6.0 * normal(rng));
      links.push_back(
          RangeLink{j + 1, x_j, B * B.transpose(), (x_pred - x_j).norm() + 0.3 * normal(rng), 0.2});
    }
    const Linearization rows = linearize_ranges(x_pred, links);
    ASSERT_EQ(rows.jacobian.rows(), 5);
    const InformationUpdate update = information_update(x_pred, Psi_pred, rows);
    ASSERT_TRUE(update.positive_definite);
    const VecX weighted = rows.innovation.cwiseQuotient(rows.variance);  // R̃⁻¹ ν
    const Vec2 expected = x_pred + update.Psi.inverse() * (rows.jacobian.transpose() * weighted);
    EXPECT_MATRIX_NEAR(update.mean, expected, 1e-9);
  }
}

TEST(Ieif, InterlacingTermAddsNeighbourVarianceAlongTheLineOfSight) {
  // r̃_j = σ_r² + u_ijᵀ P_j u_ij: with u = (1, 0) only P_j(0,0) counts.
  const std::vector<RangeLink> links = {RangeLink{1, Vec2(0.0, 0.0), Mat2{{0.3, 0.1}, {0.1, 7.0}}, 2.0, 0.5}};
  const Linearization rows = linearize_ranges(Vec2(2.0, 0.0), links);
  ASSERT_EQ(rows.variance.size(), 1);
  EXPECT_NEAR(rows.variance(0), 0.25 + 0.3, 1e-15);
}

TEST(Ieif, StaleNeighbourCovarianceIsInflatedByAgeTimesQ) {
  KalmanFilterParams params;  // Q = 0.01² I
  Inbox inbox;
  // Receiver at step 10: a message from step 9 is fresh; one from step 5 is a = 4 steps old.
  inbox.states = {state_from(1, 9, Vec2(1.0, 0.0), 0.5 * Mat2::Identity()),
                  state_from(2, 5, Vec2(0.0, 1.0), 0.5 * Mat2::Identity()),
                  state_from(3, 2, Vec2(1.0, 1.0), Mat2::Zero(), /*anchor=*/true)};
  MeasurementBatch batch;
  batch.ranges = {RangeMeasurement{1, 1.0, 0.1}, RangeMeasurement{2, 1.0, 0.1},
                  RangeMeasurement{3, 1.4, 0.1}};
  const StepInput input{10, &batch, &inbox};
  const LinkSelection on = collect_range_links(input, 0, params);
  ASSERT_EQ(on.links.size(), 3U);
  EXPECT_MATRIX_NEAR(on.links[0].neighbour_covariance, Mat2(0.5 * Mat2::Identity()), 1e-15);
  EXPECT_MATRIX_NEAR(on.links[1].neighbour_covariance, Mat2((0.5 + 4.0 * 1e-4) * Mat2::Identity()), 1e-15);
  EXPECT_MATRIX_NEAR(on.links[2].neighbour_covariance, Mat2::Zero(), 0.0);  // anchors are never inflated
  params.inflate_stale = false;
  const LinkSelection off = collect_range_links(input, 0, params);
  EXPECT_MATRIX_NEAR(off.links[1].neighbour_covariance, Mat2(0.5 * Mat2::Identity()), 1e-15);
  EXPECT_EQ(staleness_steps(10, 9), 0);
  EXPECT_EQ(staleness_steps(10, 5), 4);
  EXPECT_EQ(staleness_steps(0, 3), 0);
}

TEST(Ieif, NewestMessagePerSenderIsUsed) {
  Inbox inbox;
  inbox.states = {state_from(1, 3, Vec2(9.0, 9.0), Mat2::Identity()),
                  state_from(1, 7, Vec2(1.0, 2.0), Mat2::Identity())};
  MeasurementBatch batch;
  batch.ranges = {RangeMeasurement{1, 1.0, 0.1}};
  const LinkSelection selection = collect_range_links(StepInput{8, &batch, &inbox}, 0, KalmanFilterParams{});
  ASSERT_EQ(selection.links.size(), 1U);
  EXPECT_MATRIX_NEAR(selection.links[0].neighbour_mean_m, Vec2(1.0, 2.0), 0.0);
}

TEST(Ieif, NeighboursWithoutMessageRangeOrFiniteCovarianceAreSkipped) {
  Inbox inbox;
  inbox.states = {state_from(1, 0, Vec2(1.0, 0.0), 1e7 * Mat2::Identity()),  // trace > 1e6: skipped
                  state_from(2, 0, Vec2(0.0, 1.0), Mat2::Identity()),        // no range to it: skipped
                  state_from(4, 0, Vec2(0.0, 3.0), Mat2::Identity())};       // used
  MeasurementBatch batch;
  batch.ranges = {RangeMeasurement{1, 1.0, 0.1}, RangeMeasurement{3, 1.0, 0.1},  // 3: no message
                  RangeMeasurement{4, 3.0, 0.1}};
  const LinkSelection selection = collect_range_links(StepInput{1, &batch, &inbox}, 0, KalmanFilterParams{});
  ASSERT_EQ(selection.links.size(), 1U);
  EXPECT_EQ(selection.links[0].peer, 4);
  EXPECT_EQ(selection.skipped, 3);
}

TEST(Ieif, WithoutMeasurementsOnlyPredicts) {
  KalmanFilterParams params;
  params.initial_information = 2.0;
  params.process_noise_std_m = 0.5;
  AgentSetup setup;
  setup.initial_guess_m = Vec2(1.0, -1.0);
  Ieif ieif(setup, params);
  Inbox inbox;
  inbox.states = {state_from(1, 0, Vec2(0.0, 0.0), Mat2::Zero(), true)};
  const StepOutput out = ieif.step(StepInput{0, nullptr, &inbox});
  EXPECT_FALSE(out.diagnostics.updated);
  // Ψ = (Ψ⁻¹ + Q)⁻¹ = (0.5 + 0.25)⁻¹ I.
  EXPECT_MATRIX_NEAR(ieif.information(), Mat2(Mat2::Identity() / 0.75), 1e-12);
  EXPECT_MATRIX_NEAR(ieif.mean(), Vec2(1.0, -1.0), 0.0);
}

TEST(Ieif, SingularInformationKeepsTheMeanAndReportsInvalid) {
  KalmanFilterParams params;
  params.initial_information = 0.0;  // Ψ_0 = 0: the singular-safe prediction must cope
  AgentSetup setup;
  setup.initial_guess_m = Vec2(2.0, 0.0);
  Ieif ieif(setup, params);
  EXPECT_FALSE(ieif.estimate().valid);
  EXPECT_GT(ieif.initial_outbox().state->covariance.trace(), params.max_neighbour_variance_m2);
  Inbox inbox;
  inbox.states = {state_from(1, -1, Vec2(0.0, 0.0), Mat2::Zero(), true)};
  MeasurementBatch batch;
  batch.ranges = {RangeMeasurement{1, 2.5, 0.1}};  // one neighbour: Ψ has rank 1
  const StepOutput out = ieif.step(StepInput{0, &batch, &inbox});
  EXPECT_TRUE(out.diagnostics.updated);
  EXPECT_TRUE(ieif.information().allFinite());
  EXPECT_MATRIX_NEAR(ieif.mean(), Vec2(2.0, 0.0), 0.0);
  EXPECT_FALSE(ieif.estimate().valid);
}

TEST(Ieif, AnchorsPublishTheirKnownPositionWithZeroCovariance) {
  AgentSetup setup;
  setup.id = 3;
  setup.anchor = true;
  setup.initial_guess_m = Vec2(4.0, 5.0);
  Ieif anchor(setup, KalmanFilterParams{});
  for (const Outbox& outbox : {anchor.initial_outbox(), anchor.step(StepInput{}).outbox}) {
    ASSERT_TRUE(outbox.state.has_value());
    EXPECT_TRUE(outbox.state->anchor);
    EXPECT_MATRIX_NEAR(outbox.state->mean_m, Vec2(4.0, 5.0), 0.0);
    EXPECT_MATRIX_NEAR(outbox.state->covariance, Mat2::Zero(), 0.0);
  }
  EXPECT_TRUE(anchor.estimate().valid);
  EXPECT_MATRIX_NEAR(anchor.estimate().covariance, Mat2::Zero(), 0.0);
}

TEST(Ieif, InitialOutboxOfANonAnchorIsSkippedByNeighbours) {
  AgentSetup setup;
  setup.id = 1;
  setup.initial_guess_m = Vec2(1.0, 1.0);
  const KalmanFilterParams params;
  const Outbox first = Ieif(setup, params).initial_outbox();
  ASSERT_TRUE(first.state.has_value());
  EXPECT_GT(first.state->covariance.trace(), params.max_neighbour_variance_m2);  // 1/ε·I (+Q)
  Inbox inbox;
  inbox.states = {Received<StateMessage>{1, -1, *first.state}};
  MeasurementBatch batch;
  batch.ranges = {RangeMeasurement{1, 1.0, 0.1}};
  AgentSetup other;
  other.id = 0;
  Ieif receiver(other, params);
  const StepOutput out = receiver.step(StepInput{0, &batch, &inbox});
  EXPECT_FALSE(out.diagnostics.updated);
  EXPECT_EQ(out.diagnostics.neighbours_skipped, 1);
}

TEST(Ieif, AbsoluteFixIsFusedAsALinearMeasurement) {
  KalmanFilterParams params;
  params.initial_information = 1.0;
  params.process_noise_std_m = 0.0;
  AgentSetup setup;
  setup.initial_guess_m = Vec2(0.0, 0.0);
  Ieif ieif(setup, params);
  MeasurementBatch batch;
  batch.fix = AbsoluteFix{Vec2(2.0, -4.0), 0.5 * Mat2::Identity(), std::nullopt};
  ieif.step(StepInput{0, &batch, nullptr});
  // Ψ = I + 2I = 3I, ŷ = 0 + 2·(2, −4): x̂ = (4/3, −8/3).
  EXPECT_MATRIX_NEAR(ieif.information(), Mat2(3.0 * Mat2::Identity()), 1e-12);
  EXPECT_MATRIX_NEAR(ieif.mean(), Vec2(4.0 / 3.0, -8.0 / 3.0), 1e-12);
}

}  // namespace
}  // namespace swarmloc::estimators
