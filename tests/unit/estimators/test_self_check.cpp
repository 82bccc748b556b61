// The estimators' self-check (docs/algorithms.md §1.6): the chi-square quantile, the windowed residual
// test, and its wiring into the IEIF, the IEKF and the centralized EKF.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "named_estimators.hpp"
#include "swarmloc/core/random.hpp"
#include "swarmloc/estimators/centralized/centralized_filter.hpp"
#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/self_check.hpp"

namespace swarmloc::estimators {
namespace {

TEST(SelfCheckQuantile, StandardNormalMatchesKnownValues) {
  EXPECT_NEAR(standard_normal_upper_quantile(0.025), 1.959964, 5e-4);
  EXPECT_NEAR(standard_normal_upper_quantile(1e-4), 3.719016, 5e-4);
  EXPECT_NEAR(standard_normal_upper_quantile(0.5), 0.0, 5e-4);
  EXPECT_NEAR(standard_normal_upper_quantile(0.975), -1.959964, 5e-4);
  EXPECT_THROW((void)standard_normal_upper_quantile(0.0), std::invalid_argument);
  EXPECT_THROW((void)standard_normal_upper_quantile(1.0), std::invalid_argument);
}

TEST(SelfCheckQuantile, ChiSquareMatchesTabulatedValues) {
  struct Tabulated {
    double dof, tail, quantile;
  };
  // Exact quantiles (regularized incomplete gamma): Wilson–Hilferty is within 1.2 % from 10 dof on.
  for (const Tabulated t :
       {Tabulated{10, 0.05, 18.307}, Tabulated{10, 1e-4, 35.564}, Tabulated{50, 1e-3, 86.661},
        Tabulated{80, 1e-4, 135.783}, Tabulated{100, 0.01, 135.807}, Tabulated{100, 1e-4, 161.319},
        Tabulated{300, 1e-4, 399.756}}) {
    EXPECT_NEAR(chi_square_upper_quantile(t.dof, t.tail), t.quantile, 0.012 * t.quantile)
        << t.dof << " dof at " << t.tail;
  }
  // Few dof: above the exact value (15.137 at 1 dof), so the test errs towards not flagging.
  EXPECT_GT(chi_square_upper_quantile(1, 1e-4), 15.137);
  EXPECT_THROW((void)chi_square_upper_quantile(0, 0.01), std::invalid_argument);
}

/// Feeds `steps` steps of `per_step` residuals ν = bias + σ·n (deterministic counter-based normals) with
/// variance σ²; returns at how many steps the check flagged.
int flagged_steps(RangeResidualCheck& check, int steps, int per_step, double bias_m, std::uint64_t seed) {
  constexpr double kSigma = 0.1;
  int flagged = 0;
  for (int k = 0; k < steps; ++k) {
    for (int m = 0; m < per_step; ++m)
      check.add(bias_m + kSigma * core::standard_normal(core::hash_keys(seed, k, m)), kSigma * kSigma);
    check.end_step();
    if (check.inconsistent()) ++flagged;
  }
  return flagged;
}

TEST(RangeResidualCheck, AConsistentStreamIsNotFlagged) {
  // 3 seeds x 3000 steps x 8 residuals of exactly the declared variance: not one flag (the test's size is
  // 1e-4 per step; these fixed draws stay below the quantile throughout).
  for (const std::uint64_t seed : {1U, 2U, 3U}) {
    RangeResidualCheck check;
    EXPECT_EQ(flagged_steps(check, 3000, 8, 0.0, seed), 0) << "seed " << seed;
    EXPECT_EQ(check.residuals(), 80U);  // the window: 10 steps x 8
  }
}

TEST(RangeResidualCheck, ABiasedEstimateIsFlaggedAndClearsOnceTheBiasLeavesTheWindow) {
  RangeResidualCheck check;
  EXPECT_FALSE(check.inconsistent());  // nothing to test yet
  EXPECT_EQ(flagged_steps(check, 50, 8, 0.0, 7), 0);
  // A 0.3 m bias on 0.1 m ranges (ν²/s about 10 per residual) is flagged from its first step on.
  RangeResidualCheck biased;
  EXPECT_EQ(flagged_steps(biased, 20, 8, 0.3, 8), 20);
  EXPECT_GT(biased.statistic(), biased.threshold());
  // Steps without ranges (prediction only, or the settle phase of a DDS run) keep the verdict.
  for (int k = 0; k < 30; ++k) biased.end_step();
  EXPECT_TRUE(biased.inconsistent());
  // Once the bias is gone the flag stays only while biased residuals remain in the 10-step window.
  EXPECT_LE(flagged_steps(biased, 30, 8, 0.0, 10), 10);
  EXPECT_FALSE(biased.inconsistent());
}

TEST(RangeResidualCheck, ResidualsWithoutAUsableVarianceAreIgnored) {
  RangeResidualCheck check;
  check.add(5.0, 0.0);
  check.add(5.0, -1.0);
  check.add(5.0, std::numeric_limits<double>::infinity());
  check.add(std::numeric_limits<double>::quiet_NaN(), 1.0);
  check.end_step();
  EXPECT_EQ(check.residuals(), 0U);
  EXPECT_FALSE(check.inconsistent());
  EXPECT_THROW(RangeResidualCheck(SelfCheckParams{0, 1e-4}), std::invalid_argument);
}

// Agent 0 at (10, 10) ranges to four anchors at the corners of a 20 m square and to agent 5, whose
// broadcast estimate is 1 m off its true position (10, 16) with the covariance `neighbour_variance`·I.
// Returns whether the agent's self-check flags it after 40 steps of exact ranges (σ declared 0.1 m).
bool flagged_beside_a_displaced_neighbour(const std::string& algorithm, double neighbour_variance) {
  const Vec2 truth(10.0, 10.0);
  const std::array<Vec2, 4> anchors{Vec2(0.0, 0.0), Vec2(20.0, 0.0), Vec2(0.0, 20.0), Vec2(20.0, 20.0)};
  const Vec2 neighbour_truth(10.0, 16.0);
  AgentSetup setup;
  setup.id = 0;
  setup.initial_guess_m = Vec2(10.5, 9.5);
  KalmanFilterParams params;
  params.initial_std_m = 3.0;
  const auto estimator = testing::make_named_estimator(algorithm, setup, params);
  Inbox inbox;
  for (AgentId j = 1; j <= 4; ++j) {
    Received<StateMessage> anchor;
    anchor.sender = j;
    anchor.message.anchor = true;
    anchor.message.mean_m = anchors[static_cast<std::size_t>(j - 1)];
    inbox.states.push_back(anchor);
  }
  Received<StateMessage> neighbour;
  neighbour.sender = 5;
  neighbour.message.mean_m = neighbour_truth + Vec2(0.0, 1.0);  // 1 m off, along the range
  neighbour.message.covariance = neighbour_variance * Mat2::Identity();
  inbox.states.push_back(neighbour);
  MeasurementBatch batch;
  for (AgentId j = 1; j <= 4; ++j)
    batch.ranges.push_back({j, (truth - anchors[static_cast<std::size_t>(j - 1)]).norm(), 0.1});
  batch.ranges.push_back({5, (truth - neighbour_truth).norm(), 0.1});
  for (std::int64_t k = 0; k < 40; ++k) {
    batch.world_step = k;
    for (auto& state : inbox.states) state.sender_step = k - 1;
    (void)estimator->step(StepInput{k, &batch, &inbox});
  }
  return estimator->estimate().inconsistent;
}

TEST(FilterSelfCheck, ANeighbourWhoseCovarianceCoversItsErrorDoesNotFlagTheAgent) {
  for (const std::string algorithm : {"ieif", "iekf"}) {
    SCOPED_TRACE(algorithm);
    // The 1 m error is within the neighbour's 1 m std: the range's residual fits s = σ² + uᵀP_j u + …
    EXPECT_FALSE(flagged_beside_a_displaced_neighbour(algorithm, 1.0));
    // The same error with a claimed 1 cm std cannot be explained: the agent's data are inconsistent.
    EXPECT_TRUE(flagged_beside_a_displaced_neighbour(algorithm, 1e-4));
  }
}

TEST(FilterSelfCheck, AStartFarOffIsCoveredByTheAgentsOwnPrior) {
  // 2.5 m off with the default priors (IEIF Ψ_0 = 1e−6 I, IEKF 8.66 m std): the first innovations are
  // metres, but so is the agent's own uncertainty, uᵀP_i u.
  const std::array<Vec2, 4> anchors{Vec2(0.0, 0.0), Vec2(20.0, 0.0), Vec2(0.0, 20.0), Vec2(20.0, 20.0)};
  for (const std::string algorithm : {"ieif", "iekf"}) {
    SCOPED_TRACE(algorithm);
    AgentSetup setup;
    setup.initial_guess_m = Vec2(12.0, 11.5);
    const auto estimator = testing::make_named_estimator(algorithm, setup, KalmanFilterParams{});
    Inbox inbox;
    MeasurementBatch batch;
    for (AgentId j = 1; j <= 4; ++j) {
      Received<StateMessage> anchor;
      anchor.sender = j;
      anchor.sender_step = -1;
      anchor.message.anchor = true;
      anchor.message.mean_m = anchors[static_cast<std::size_t>(j - 1)];
      inbox.states.push_back(anchor);
      batch.ranges.push_back({j, (Vec2(10.0, 10.0) - anchors[static_cast<std::size_t>(j - 1)]).norm(), 0.1});
    }
    (void)estimator->step(StepInput{0, &batch, &inbox});
    EXPECT_FALSE(estimator->estimate().inconsistent);
  }
}

TEST(FilterSelfCheck, AnAnchorIsNeverFlagged) {
  AgentSetup setup;
  setup.anchor = true;
  const auto estimator = testing::make_named_estimator("ieif", setup, KalmanFilterParams{});
  MeasurementBatch batch;
  batch.ranges.push_back({1, 100.0, 0.1});
  Inbox inbox;
  for (std::int64_t k = 0; k < 20; ++k) (void)estimator->step(StepInput{k, &batch, &inbox});
  EXPECT_FALSE(estimator->estimate().inconsistent);
}

/// The centralized EKF on four beacons and agent 4 at (10, 10), started `start_offset_m` off with a
/// confident 0.1 m prior; ranges drawn with σ = 0.1 m. Returns agent 4's verdict after each step.
std::vector<bool> ekf_verdicts(double start_offset_m, int steps) {
  namespace centralized = estimators::centralized;
  const std::vector<Vec2> truth{Vec2(0, 0), Vec2(20, 0), Vec2(0, 20), Vec2(20, 20), Vec2(10, 10)};
  VecX initial_mean(10);
  for (int a = 0; a < 5; ++a) initial_mean.segment<2>(2 * a) = truth[static_cast<std::size_t>(a)];
  initial_mean.segment<2>(8) += Vec2(start_offset_m, 0.0);
  std::vector<Mat2> initial_cov(5, 1e-6 * Mat2::Identity());
  initial_cov[4] = 0.01 * Mat2::Identity();
  centralized::CentralizedFilterParams params;
  params.process_var = 1e-4;
  const auto filter = centralized::make_centralized_filter(centralized::CentralizedKind::kEkf, initial_mean,
                                                           initial_cov, params);
  std::vector<bool> verdicts;
  for (int k = 0; k < steps; ++k) {
    centralized::CentralizedMeasurements meas;
    meas.beacon_var = 1e-6;
    meas.range_var = 0.01;
    for (int a = 0; a < 4; ++a) {
      meas.beacon_fixes.emplace_back(a, truth[static_cast<std::size_t>(a)]);
      const double noise = 0.1 * core::standard_normal(core::hash_keys(11, k, a));
      meas.ranges.push_back({a, 4, (truth[4] - truth[static_cast<std::size_t>(a)]).norm() + noise});
    }
    filter->step(meas);
    verdicts.push_back(filter->inconsistent(4));
  }
  return verdicts;
}

TEST(FilterSelfCheck, TheCentralizedEkfFlagsAnAgentStartedConfidentlyWrongUntilItRecovers) {
  const auto healthy = ekf_verdicts(0.0, 60);
  for (std::size_t k = 0; k < healthy.size(); ++k) EXPECT_FALSE(healthy[k]) << "step " << k;
  // 2 m off with a 0.1 m std: the first innovations are 20σ. The EKF recovers within a few steps and
  // the flag clears once those innovations leave the 10-step window.
  const auto wrong = ekf_verdicts(2.0, 60);
  EXPECT_TRUE(wrong[0]);
  EXPECT_TRUE(wrong[5]);
  EXPECT_FALSE(wrong[40]);
  EXPECT_FALSE(wrong[59]);
}

/// Anchors 0 (0, 0), 1 (10, 0), 4 (5, −13); agent 3 at (5, −6) ranges all three, agent 2 at (5, 4) only
/// anchors 0 and 1, so its mirror image (5, −4) fits its ranges as well, yet lies 2 m from agent 3, which
/// it never ranged with (radius 8 m). Returns the `kind` filter's verdict on agents 2, 3 and anchor 0
/// after `steps` steps with agent 2 started at `start_of_agent_2`.
std::array<bool, 3> mirror_world_verdicts(estimators::centralized::CentralizedKind kind,
                                          const Vec2& start_of_agent_2, double disk_radius_m, int steps) {
  namespace centralized = estimators::centralized;
  const std::vector<Vec2> truth{Vec2(0, 0), Vec2(10, 0), Vec2(5, 4), Vec2(5, -6), Vec2(5, -13)};
  const std::vector<std::pair<int, int>> ranged{{0, 2}, {1, 2}, {0, 3}, {1, 3}, {3, 4}};
  VecX initial_mean(10);
  for (int a = 0; a < 5; ++a) initial_mean.segment<2>(2 * a) = truth[static_cast<std::size_t>(a)];
  initial_mean.segment<2>(4) = start_of_agent_2;
  const std::vector<Mat2> initial_cov(5, 0.01 * Mat2::Identity());
  centralized::CentralizedFilterParams params;
  params.process_var = 1e-6;
  params.disk_radius_m = disk_radius_m;
  const auto filter = centralized::make_centralized_filter(kind, initial_mean, initial_cov, params);
  for (int k = 0; k < steps; ++k) {
    centralized::CentralizedMeasurements meas;
    meas.beacon_var = 1e-6;
    meas.range_var = 0.01;
    for (const int anchor : {0, 1, 4})
      meas.beacon_fixes.emplace_back(anchor, truth[static_cast<std::size_t>(anchor)]);
    for (const auto& [i, j] : ranged) {
      const double noise = 0.1 * core::standard_normal(core::hash_keys(12, k, i, j));
      meas.ranges.push_back(
          {i, j, (truth[static_cast<std::size_t>(i)] - truth[static_cast<std::size_t>(j)]).norm() + noise});
    }
    filter->step(meas);
  }
  return {filter->inconsistent(2), filter->inconsistent(3), filter->inconsistent(0)};
}

TEST(FilterSelfCheck, AFusionCentreFlagsAMirrorImageInsideTheRadiusOfAnAgentItNeverRanged) {
  namespace centralized = estimators::centralized;
  const Vec2 mirror(5, -4);
  for (const auto kind : {centralized::CentralizedKind::kEkf, centralized::CentralizedKind::kLbEkf,
                          centralized::CentralizedKind::kLbEkfI}) {
    SCOPED_TRACE(std::string(centralized::to_string(kind)));
    // Every range fits the mirror image: only the graph tells it apart, once the patience has passed.
    EXPECT_EQ(mirror_world_verdicts(kind, mirror, 0.0, 30), (std::array{false, false, false}));
    EXPECT_EQ(mirror_world_verdicts(kind, mirror, 8.0, 5), (std::array{false, false, false}));
    EXPECT_EQ(mirror_world_verdicts(kind, mirror, 8.0, 30), (std::array{true, true, false}));
    // On the true side agent 2 is 10 m from agent 3: nothing to flag.
    EXPECT_EQ(mirror_world_verdicts(kind, Vec2(5, 4), 8.0, 30), (std::array{false, false, false}));
  }
}

}  // namespace
}  // namespace swarmloc::estimators
