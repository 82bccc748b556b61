#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "eigen_gtest.hpp"
#include "kalman_reference.hpp"
#include "swarmloc/estimators/kalman/ieif.hpp"
#include "swarmloc/estimators/kalman/iekf.hpp"
#include "swarmloc/estimators/kalman/kernels.hpp"

namespace swarmloc::estimators {
namespace {

Received<StateMessage> kalman_state_from(AgentId sender, std::int64_t step, const Vec2& mean, const Mat2& cov,
                                         bool anchor) {
  Received<StateMessage> r;
  r.sender = sender;
  r.sender_step = step;
  r.message.mean_m = mean;
  r.message.covariance = cov;
  r.message.anchor = anchor;
  return r;
}

TEST(InformationForm, EqualsKalmanFormForALinearMeasurement) {
  // Arbitrary (non-unit) rows H with diagonal R plus a correlated 2-D fix: the information update
  // Ψ⁺ = Ψ + HᵀR⁻¹H, ŷ⁺ = ŷ + HᵀR⁻¹z must equal the Kalman update with P = Ψ⁻¹.
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const Mat2 A = Mat2::Random();
    const Mat2 Psi = A * A.transpose() + 0.05 * Mat2::Identity();
    const Vec2 x(normal(rng), normal(rng));
    Linearization rows;
    rows.jacobian = Eigen::Matrix<double, Eigen::Dynamic, 2>::Random(4, 2) * 3.0;
    rows.innovation = VecX::Random(4);
    rows.variance = VecX::Random(4).cwiseAbs() + VecX::Constant(4, 0.1);
    const Mat2 C = Mat2::Random();
    rows.fix =
        AbsoluteFix{Vec2(normal(rng), normal(rng)), C * C.transpose() + 0.2 * Mat2::Identity(), std::nullopt};

    const InformationUpdate info = information_update(x, Psi, rows);
    const KalmanUpdate kalman = kalman_update(x, Psi.inverse(), rows);
    ASSERT_TRUE(info.positive_definite);
    EXPECT_MATRIX_NEAR(info.mean, kalman.mean, 1e-9);
    EXPECT_MATRIX_NEAR(info.Psi.inverse(), kalman.covariance, 1e-9);
  }
}

// Also with the iterated update (algorithm.update_iterations), which the IEKF runs in information form.
TEST(InformationForm, IeifAndIekfAgreeWhenP0EqualsInversePsi0) {
  for (const int iterations : {1, 10}) {
    SCOPED_TRACE(iterations);
    // docs/algorithms.md §3.5: algebraically equivalent when P_0 = Ψ_0⁻¹. Ψ_0 = 0.04 I  <=>  σ_0 = 5 m.
    KalmanFilterParams params;
    params.update_iterations = iterations;
    params.initial_information = 0.04;
    params.initial_std_m = 5.0;
    params.process_noise_std_m = 0.05;
    AgentSetup setup;
    setup.id = 0;
    setup.initial_guess_m = Vec2(4.0, 3.0);
    Ieif ieif(setup, params);
    Iekf iekf(setup, params);

    const Vec2 truth(5.0, 5.0);
    Inbox inbox;
    inbox.states = {kalman_state_from(1, -1, Vec2(0.0, 0.0), Mat2::Zero(), true),
                    kalman_state_from(2, -1, Vec2(10.0, 0.0), Mat2::Zero(), true),
                    kalman_state_from(3, -1, Vec2(9.0, 9.5), Mat2{{0.2, 0.05}, {0.05, 0.1}}, false),
                    kalman_state_from(4, -1, Vec2(1.0, 8.0), 0.3 * Mat2::Identity(), false)};
    const std::vector<Vec2> neighbour_truth = {Vec2(0.0, 0.0), Vec2(10.0, 0.0), Vec2(9.2, 9.4),
                                               Vec2(0.8, 8.3)};
    std::mt19937_64 rng(3);
    std::normal_distribution<double> noise(0.0, 0.1);
    for (std::int64_t k = 0; k < 5; ++k) {
      MeasurementBatch batch;
      batch.world_step = k;
      for (int j = 0; j < 4; ++j) {
        batch.ranges.push_back(RangeMeasurement{
            j + 1, (truth - neighbour_truth[static_cast<std::size_t>(j)]).norm() + noise(rng), 0.1});
      }
      for (auto& s : inbox.states) s.sender_step = k - 1;
      const StepInput input{k, &batch, &inbox};
      const StepOutput a = ieif.step(input);
      const StepOutput b = iekf.step(input);
      EXPECT_EQ(a.diagnostics.neighbours_used, 4);
      EXPECT_EQ(b.diagnostics.neighbours_used, 4);
      EXPECT_MATRIX_NEAR(ieif.mean(), iekf.mean(), 1e-9) << "step " << k;
      EXPECT_MATRIX_NEAR(ieif.estimate().covariance, iekf.estimate().covariance, 1e-9) << "step " << k;
      EXPECT_MATRIX_NEAR(a.outbox.state->covariance, b.outbox.state->covariance, 1e-9) << "step " << k;
    }
    EXPECT_LT((ieif.mean() - truth).norm(), 0.3);
  }
}

TEST(InformationForm, IeifAndIekfAgreeOnAGpsOnlyStep) {
  KalmanFilterParams params;
  params.initial_information = 0.25;  // P_0 = 4 I
  params.initial_std_m = 2.0;
  AgentSetup setup;
  setup.initial_guess_m = Vec2(1.0, 1.0);
  Ieif ieif(setup, params);
  Iekf iekf(setup, params);
  MeasurementBatch batch;
  batch.fix = AbsoluteFix{Vec2(2.0, 0.5), Mat2{{0.5, 0.2}, {0.2, 0.3}}, std::nullopt};
  const StepInput input{0, &batch, nullptr};
  EXPECT_TRUE(ieif.step(input).diagnostics.updated);
  EXPECT_TRUE(iekf.step(input).diagnostics.updated);
  EXPECT_MATRIX_NEAR(ieif.mean(), iekf.mean(), 1e-12);
  EXPECT_MATRIX_NEAR(ieif.estimate().covariance, iekf.estimate().covariance, 1e-12);
}

TEST(Iekf, JosephUpdateMatchesTheTextbookKalmanUpdate) {
  // One scalar row: K = P hᵀ/(h P hᵀ + r), x⁺ = x + K ν, P⁺ = (I − K h) P.
  const Mat2 P{{2.0, 0.5}, {0.5, 1.0}};
  Linearization rows;
  rows.jacobian = Eigen::Matrix<double, 1, 2>(0.6, 0.8);
  rows.innovation = VecX::Constant(1, 0.3);
  rows.variance = VecX::Constant(1, 0.04);
  const Eigen::RowVector2d h(0.6, 0.8);
  const double s = h * P * h.transpose() + 0.04;
  const Vec2 K = P * h.transpose() / s;
  const KalmanUpdate update = kalman_update(Vec2(1.0, 2.0), P, rows);
  EXPECT_MATRIX_NEAR(update.mean, Vec2(Vec2(1.0, 2.0) + K * 0.3), 1e-12);
  EXPECT_MATRIX_NEAR(update.covariance, Mat2((Mat2::Identity() - K * h) * P), 1e-12);
}

TEST(Iekf, TwoByTwoUpdateEqualsTheMByMInnovationCovarianceForm) {
  // kalman_update never forms the M×M S = H P Hᵀ + R; compare with that textbook form (Joseph) for many
  // rows plus a correlated fix, including a singular P (which the push-through form must not invert).
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Index ranges = 50;
    const Mat2 B = Mat2::Random();
    const Mat2 P = trial % 4 == 0 ? Mat2(Vec2(1.0, -2.0) * Vec2(1.0, -2.0).transpose())  // rank 1
                                  : Mat2(B * B.transpose() + 0.01 * Mat2::Identity());
    const Vec2 x(normal(rng), normal(rng));
    Linearization rows;
    rows.jacobian = Eigen::Matrix<double, Eigen::Dynamic, 2>::Random(ranges, 2);
    rows.innovation = VecX::Random(ranges);
    rows.variance = VecX::Random(ranges).cwiseAbs() + VecX::Constant(ranges, 0.01);
    const Mat2 C = Mat2::Random();
    rows.fix =
        AbsoluteFix{Vec2(normal(rng), normal(rng)), C * C.transpose() + 0.2 * Mat2::Identity(), std::nullopt};

    const KalmanUpdate expected = testing::kalman_update_innovation_form(x, P, rows);
    const KalmanUpdate update = kalman_update(x, P, rows);
    EXPECT_MATRIX_NEAR(update.mean, expected.mean, 1e-9) << "trial " << trial;
    EXPECT_MATRIX_NEAR(update.covariance, expected.covariance, 1e-9) << "trial " << trial;
  }
}

}  // namespace
}  // namespace swarmloc::estimators
