#include <gtest/gtest.h>

#include <cmath>

#include "eigen_gtest.hpp"
#include "swarmloc/estimators/consensus/dle.hpp"

namespace swarmloc::estimators::consensus {
namespace {

TEST(Dle, OneStepCombinesPriorsWithMetropolisWeightsAndAddsTheObservation) {
  DleParams params;
  params.target_dim = 2;
  AgentSetup setup;
  setup.id = 0;
  Dle node(setup, params);
  // Node 0 has degree 1; neighbour 1 has degree 3: κ_01 = 1/(1 + 3) = 0.25, κ_00 = 0.75.
  Inbox inbox;
  StateMessage state;
  state.degree = 3;
  inbox.states.push_back({1, 0, state});
  inbox.information.push_back({1, 0, InformationMessage{0, Vec2(4.0, 8.0), Mat2(4.0 * Mat2::Identity())}});
  MeasurementBatch batch;
  batch.neighbours = {1};
  batch.targets = {TargetObservation{0, Vec2(1.0, 2.0), Mat2(0.5 * Mat2::Identity()), 0}};
  node.step(StepInput{0, &batch, &inbox});
  // ω⁺ = 0.25·(4, 8) + 2·(1, 2) = (3, 6); Ω⁺ = 0.25·4 I + 2 I = 3 I; ŷ = (1, 2).
  EXPECT_MATRIX_NEAR(node.info_vec(), VecX(Vec2(3.0, 6.0)), 1e-12);
  EXPECT_MATRIX_NEAR(node.info_mat(), MatX(3.0 * Mat2::Identity()), 1e-12);
  ASSERT_TRUE(node.has_target_estimate());
  EXPECT_MATRIX_NEAR(node.target_estimate(), VecX(Vec2(1.0, 2.0)), 1e-12);
}

TEST(Dle, EstimateIsTheTargetPositionWithTheInverseOfTheUpdatedInformation) {
  DleParams params;
  params.target_dim = 4;  // position and velocity; kind-0 readings see the position (H = [I 0])
  params.F = MatX::Identity(4, 4);
  params.W = 0.01 * MatX::Identity(4, 4);
  params.initial_information = 0.5;
  AgentSetup setup;
  setup.initial_guess_m = Vec2(-7.0, 3.0);  // the sensor's own position, which is not what it reports
  Dle node(setup, params);
  EXPECT_FALSE(node.estimate().valid) << "no estimate before the first step";
  MeasurementBatch batch;
  batch.targets = {TargetObservation{0, Vec2(1.0, 2.0), Mat2(0.25 * Mat2::Identity()), 0}};
  const Inbox inbox;
  node.step(StepInput{0, &batch, &inbox});
  // No neighbours: Ω⁺ = 0.5 I + diag(4, 4, 0, 0); ŷ = Ω⁺⁻¹ (4·(1, 2), 0, 0) = (8/9)(1, 2, 0, 0).
  const Estimate estimate = node.estimate();
  ASSERT_TRUE(estimate.valid);
  EXPECT_MATRIX_NEAR(estimate.mean_m, Vec2(Vec2(1.0, 2.0) * 8.0 / 9.0), 1e-12);
  EXPECT_MATRIX_NEAR(estimate.covariance, Mat2(Mat2::Identity() / 4.5), 1e-12);
}

// A free-running sensor may step without a batch, or get two world steps' batches at once. Its prior must
// follow world time, not its own step count: the same readings give the same estimate either way.
/// A planar double integrator (position, velocity), τ = 0.1 s, as the tracking tests use.
DleParams double_integrator() {
  DleParams params;
  params.target_dim = 4;
  params.F = MatX::Identity(4, 4);
  params.F.topRightCorner<2, 2>() = 0.1 * Mat2::Identity();
  params.W = 0.01 * MatX::Identity(4, 4);
  params.initial_information = 1e-3;
  return params;
}

TEST(Dle, TrackingPredictsByWorldStepsNotBySensorSteps) {
  const DleParams params = double_integrator();
  const auto batch = [](std::int64_t world_step, bool with_reading) {
    MeasurementBatch b;
    b.world_step = world_step;
    if (with_reading)
      b.targets = {TargetObservation{0, Vec2(1.0 + world_step, 2.0), Mat2(0.25 * Mat2::Identity()), 0}};
    return b;
  };
  const Inbox inbox;
  const AgentSetup setup;
  // Every world step in order, one batch each (step 1 holds no reading).
  Dle in_order(setup, params);
  for (std::int64_t k = 0; k < 3; ++k) {
    const auto b = batch(k, k != 1);
    in_order.step(StepInput{k, &b, &inbox});
  }
  // The batch of step 1 never came; a step without a batch in between.
  Dle skipped(setup, params);
  const auto b0 = batch(0, true);
  const auto b2 = batch(2, true);
  skipped.step(StepInput{0, &b0, &inbox});
  const Estimate after_first = skipped.estimate();
  const VecX prior_after_first = skipped.info_vec();
  skipped.step(StepInput{1, nullptr, &inbox});
  EXPECT_EQ(skipped.estimate().mean_m, after_first.mean_m) << "no batch: the estimate stays";
  EXPECT_MATRIX_NEAR(skipped.info_vec(), prior_after_first, 1e-12)
      << "no batch, no neighbours: no prediction";
  skipped.step(StepInput{2, &b2, &inbox});
  EXPECT_MATRIX_NEAR(skipped.target_estimate(), in_order.target_estimate(), 1e-9);
  EXPECT_MATRIX_NEAR(skipped.info_mat(), in_order.info_mat(), 1e-6);
}

TEST(Dle, AnAbsurdWorldStepGapPredictsABoundedNumberOfPeriods) {
  Dle node(AgentSetup{}, double_integrator());
  const Inbox inbox;
  MeasurementBatch batch;
  batch.world_step = 0;
  batch.targets = {TargetObservation{0, Vec2(1.0, 2.0), Mat2::Identity(), 0}};
  node.step(StepInput{0, &batch, &inbox});
  batch.world_step = std::int64_t{1} << 60;  // ~10^18 periods: must not loop that often
  node.step(StepInput{1, &batch, &inbox});
  ASSERT_TRUE(node.estimate().valid);
  EXPECT_TRUE(node.target_estimate().allFinite());
  EXPECT_TRUE(node.info_mat().allFinite());
}

/// One tracking step of a fresh sensor (prior ε I, no world step yet) that reads z at world step 5 and has
/// one neighbour (κ = 1/2 each) whose prior (ω, Ω) is about `neighbour_world_step`.
struct AlignedStep {
  Dle node{AgentSetup{}, double_integrator()};
  StepOutput output;
  AlignedStep(const VecX& omega, const MatX& Omega, std::int64_t neighbour_world_step) {
    Inbox inbox;
    inbox.information.push_back({1, 0, InformationMessage{0, omega, Omega, neighbour_world_step}});
    MeasurementBatch batch;
    batch.world_step = 5;
    batch.neighbours = {1};
    batch.targets = {TargetObservation{0, Vec2(1.3, 1.7), Mat2(0.25 * Mat2::Identity()), 0}};
    output = node.step(StepInput{0, &batch, &inbox});
  }
  /// ŷ of the step had the neighbour's prior been (ω', Ω') about world step 5 (κ = 1/2; no κ: alone).
  static VecX expected(const VecX& omega5, const MatX& Omega5, double kappa = 0.5) {
    MatX H = MatX::Zero(2, 4);
    H.leftCols<2>().setIdentity();
    const MatX Omega_plus =
        (1.0 - kappa) * 1e-3 * MatX::Identity(4, 4) + kappa * Omega5 + 4.0 * H.transpose() * H;
    const VecX omega_plus = kappa * omega5 + 4.0 * H.transpose() * Vec2(1.3, 1.7);
    return Omega_plus.ldlt().solve(omega_plus);
  }
};

TEST(Dle, ANeighboursOlderPriorIsPredictedToTheReadingsWorldStepBeforeMixing) {
  const DleParams params = double_integrator();
  VecX mean3(4);
  mean3 << 1.0, 2.0, 0.5, -0.5;
  const MatX P3 = VecX((VecX(4) << 0.2, 0.3, 0.05, 0.05).finished()).asDiagonal();
  const MatX Omega3 = P3.inverse();
  const AlignedStep step(Omega3 * mean3, Omega3, 3);
  // Two periods ahead in covariance form: the neighbour's prior as it would be at world step 5.
  const MatX& F = params.F;
  const MatX P5 = F * (F * P3 * F.transpose() + params.W) * F.transpose() + params.W;
  const MatX Omega5 = P5.inverse();
  ASSERT_TRUE(step.node.has_target_estimate());
  EXPECT_MATRIX_NEAR(step.node.target_estimate(), AlignedStep::expected(Omega5 * (F * F * mean3), Omega5),
                     1e-9);
  ASSERT_TRUE(step.output.outbox.information.has_value());
  EXPECT_EQ(step.output.outbox.information->world_step, 6) << "the published prior is predicted one step on";
}

TEST(Dle, ANeighboursNewerPriorIsTakenBackWithoutRemovingTheProcessNoise) {
  const DleParams params = double_integrator();
  VecX mean7(4);
  mean7 << 1.2, 1.8, 0.5, -0.5;
  const MatX Omega7 = VecX((VecX(4) << 4.0, 3.0, 20.0, 20.0).finished()).asDiagonal();
  const AlignedStep step(Omega7 * mean7, Omega7, 7);
  // Back two periods: Ω' = (F²)ᵀ Ω F², ω' = (F²)ᵀ ω — mean F⁻² m, covariance F⁻² P F⁻²ᵀ (≥ the true one).
  const MatX F2 = params.F * params.F;
  const MatX Omega5 = F2.transpose() * Omega7 * F2;
  EXPECT_MATRIX_NEAR(step.node.target_estimate(),
                     AlignedStep::expected(F2.transpose() * (Omega7 * mean7), Omega5), 1e-9);
  EXPECT_MATRIX_NEAR(VecX(Omega5.ldlt().solve(F2.transpose() * (Omega7 * mean7))), VecX(F2.inverse() * mean7),
                     1e-12);
}

TEST(Dle, ANeighboursPriorMoreThanAThousandWorldStepsAwayIsDropped) {
  const MatX Omega = 4.0 * MatX::Identity(4, 4);
  const VecX omega = Omega * VecX::Constant(4, 9.0);
  for (const std::int64_t far : {std::int64_t{5 + 1001}, std::int64_t{1} << 60}) {
    const AlignedStep step(omega, Omega, far);
    EXPECT_EQ(step.output.diagnostics.neighbours_skipped, 1) << far;
    EXPECT_EQ(step.output.diagnostics.neighbours_used, 0) << far;
    EXPECT_MATRIX_NEAR(step.node.target_estimate(), AlignedStep::expected(omega, Omega, 0.0), 1e-9) << far;
  }
}

TEST(Dle, AStaticTargetsPriorIsNotTiedToAWorldStep) {
  Dle node(AgentSetup{}, DleParams{});
  MeasurementBatch batch;
  batch.world_step = 5;
  batch.targets = {TargetObservation{0, Vec2(1.0, 1.0), Mat2::Identity(), 0}};
  const Inbox inbox;
  const auto output = node.step(StepInput{0, &batch, &inbox});
  ASSERT_TRUE(output.outbox.information.has_value());
  EXPECT_EQ(output.outbox.information->world_step, -1);
}

TEST(Dle, MissingNeighbourIsDroppedAndTheWeightReturnsToSelf) {  // docs/algorithms.md §4.5
  DleParams params;
  AgentSetup setup;
  Dle node(setup, params);
  MeasurementBatch batch;
  batch.neighbours = {1, 2};
  batch.targets = {TargetObservation{0, Vec2(1.0, 1.0), Mat2::Identity(), 0}};
  Inbox inbox;  // nothing received: the prior is kept whole (κ_ii = 1)
  node.step(StepInput{0, &batch, &inbox});
  node.step(StepInput{1, &batch, &inbox});
  EXPECT_MATRIX_NEAR(node.info_mat(), MatX(2.0 * Mat2::Identity()), 1e-12);
}

TEST(Dle, TrackingPredictionUsesTheUpdatedInformation) {  // [C-2]
  DleParams params;
  params.target_dim = 2;
  params.F = 2.0 * MatX::Identity(2, 2);
  params.W = MatX::Identity(2, 2);
  params.initial_information = 1e-6;
  AgentSetup setup;
  Dle node(setup, params);
  MeasurementBatch batch;
  batch.targets = {TargetObservation{0, Vec2(1.0, -1.0), Mat2::Identity(), 0}};
  Inbox inbox;
  node.step(StepInput{0, &batch, &inbox});
  // Ω⁺ = (1 + 1e−6) I; P⁺ = I/(1 + 1e−6); Ω_1 = (4 P⁺ + I)⁻¹; ω_1 = Ω_1 F ŷ.
  const double p = 1.0 / (1.0 + 1e-6);
  const double omega = 1.0 / (4.0 * p + 1.0);
  EXPECT_MATRIX_NEAR(node.info_mat(), MatX(omega * Mat2::Identity()), 1e-12);
  EXPECT_MATRIX_NEAR(node.info_vec(), VecX(omega * 2.0 * p * Vec2(1.0, -1.0)), 1e-12);
}

// Range–bearing (kind 1) across the ±π cut: the predicted bearing is +π − ε, the measured one −π + ε. A
// wrapped residual moves the estimate by millimetres; an unwrapped one (−2π) would put it ~190 m away.
TEST(Dle, RangeBearingIsLinearizedAtThePredictionWithTheBearingResidualWrapped) {
  DleParams params;
  params.target_dim = 2;
  const Vec2 truth(-25.0, 2.0 - 1e-4);
  params.initial_mean = Vec2(-25.0, 2.0 + 1e-4);
  AgentSetup setup;
  setup.initial_guess_m = Vec2(5.0, 2.0);
  Dle node(setup, params);
  const Vec2 d = truth - setup.initial_guess_m;
  MeasurementBatch batch;
  batch.targets = {
      TargetObservation{0, Vec2(d.norm(), std::atan2(d.y(), d.x())), Mat2(Vec2(0.01, 1e-6).asDiagonal()), 1}};
  ASSERT_LT(batch.targets[0].value(1), -3.14);
  Inbox inbox;
  node.step(StepInput{0, &batch, &inbox});
  ASSERT_TRUE(node.has_target_estimate());
  // One Gauss–Newton step from 2e-4 m away: the linearization error is second order (~1e-9 m).
  EXPECT_LT((node.target_estimate() - VecX(truth)).norm(), 1e-6);
}

TEST(Dle, RangeBearingToAOneDimensionalTargetIsSkipped) {
  DleParams params;
  params.target_dim = 1;
  params.H = MatX::Ones(2, 1);
  Dle node(AgentSetup{}, params);
  MeasurementBatch batch;
  batch.targets = {TargetObservation{0, Vec2(10.0, 0.5), Mat2::Identity(), 1}};
  Inbox inbox;
  EXPECT_FALSE(node.step(StepInput{0, &batch, &inbox}).diagnostics.updated);
}

TEST(Dle, RejectsMismatchedDimensions) {
  DleParams params;
  params.target_dim = 3;
  params.H = MatX::Identity(2, 2);
  EXPECT_THROW(validate(params), std::invalid_argument);
}

}  // namespace
}  // namespace swarmloc::estimators::consensus
