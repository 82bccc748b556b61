#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <random>
#include <stdexcept>

#include "eigen_gtest.hpp"
#include "swarmloc/estimators/crlb.hpp"

namespace swarmloc::estimators {
namespace {

// Anchors 0 at (0, 0) and 1 at (6, 0), agent 2 at (3, 4): u_20 = (0.6, 0.8), u_21 = (−0.6, 0.8).
const std::vector<Vec2> kTruth = {Vec2(0.0, 0.0), Vec2(6.0, 0.0), Vec2(3.0, 4.0)};
const std::vector<bool> kAnchor = {true, true, false};

TEST(Crlb, TwoAnchorsAndOneAgentMatchHandArithmetic) {
  // σ = 0.5: J = 4·(uuᵀ₀ + uuᵀ₁) = 4·diag(0.72, 1.28) = diag(2.88, 5.12); CRB = diag(1/2.88, 1/5.12).
  const std::vector<RangeObservation> ranges = {{2, 0, 0.5}, {2, 1, 0.5}};
  const CrlbResult r = range_network_crlb(kTruth, kAnchor, ranges);
  ASSERT_TRUE(r.localizable);
  EXPECT_MATRIX_NEAR(r.per_agent[2], Mat2(Vec2(1.0 / 2.88, 1.0 / 5.12).asDiagonal()), 1e-12);
  EXPECT_MATRIX_NEAR(r.per_agent[0], Mat2::Zero(), 0.0);
  EXPECT_DOUBLE_EQ(r.per_agent_rmse_m[0], 0.0);
  EXPECT_NEAR(r.per_agent_rmse_m[2], std::sqrt(1.0 / 2.88 + 1.0 / 5.12), 1e-12);
  EXPECT_NEAR(r.network_rmse_m, std::sqrt(1.0 / 2.88 + 1.0 / 5.12), 1e-12);  // n_u = 1
}

TEST(Crlb, MutualObservationsCountEachDirectionOnce) {
  const auto ranges = mutual_range_observations(kTruth, kAnchor, 0.5);
  EXPECT_EQ(ranges.size(), 4U);  // 2→0, 2→1, 0→2, 1→2; no anchor–anchor pair
  const CrlbResult r = range_network_crlb(kTruth, kAnchor, ranges);
  EXPECT_MATRIX_NEAR(r.per_agent[2], Mat2(0.5 * Vec2(1.0 / 2.88, 1.0 / 5.12).asDiagonal()), 1e-12);
  EXPECT_EQ(mutual_range_observations(kTruth, kAnchor, 0.5, /*radius_m=*/5.5).size(), 4U);
  EXPECT_EQ(mutual_range_observations(kTruth, kAnchor, 0.5, /*radius_m=*/4.0).size(), 0U);
}

TEST(Crlb, AccumulatedOverSnapshotsEqualsSingleDividedByCount) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> uniform(0.0, 30.0);
  std::vector<Vec2> truth;
  std::vector<bool> anchor;
  for (int i = 0; i < 20; ++i) {
    truth.emplace_back(uniform(rng), uniform(rng));
    anchor.push_back(i < 5);
  }
  const auto ranges = mutual_range_observations(truth, anchor, 0.2, 25.0);
  const CrlbResult one = range_network_crlb(truth, anchor, ranges);
  const CrlbResult many = range_network_crlb(truth, anchor, ranges, 37.0);
  ASSERT_TRUE(one.localizable);
  for (std::size_t i = 0; i < truth.size(); ++i) {
    EXPECT_MATRIX_NEAR(many.per_agent[i], Mat2(one.per_agent[i] / 37.0), 1e-12);
  }
  EXPECT_NEAR(many.network_rmse_m, one.network_rmse_m / std::sqrt(37.0), 1e-12);
}

TEST(Crlb, PriorInformationAddsToAccumulatedInformation) {
  // J_t = J_prior + t·J_1 on the hand case: diag(2.88, 5.12)·3 + diag(1, 2).
  const std::vector<RangeObservation> ranges = {{2, 0, 0.5}, {2, 1, 0.5}};
  const std::vector<Mat2> prior = {Mat2::Identity(), Mat2::Identity(), Mat2(Vec2(1.0, 2.0).asDiagonal())};
  const CrlbResult r = range_network_crlb(kTruth, kAnchor, ranges, 3.0, &prior);
  EXPECT_MATRIX_NEAR(r.per_agent[2], Mat2(Vec2(1.0 / (3 * 2.88 + 1.0), 1.0 / (3 * 5.12 + 2.0)).asDiagonal()),
                     1e-12);
}

TEST(Crlb, GpsFixAddsInverseCovariance) {
  RangeNetwork net;
  net.truth = {Vec2(0.0, 0.0)};
  net.is_anchor = {false};
  net.absolute = {AbsoluteObservation{0, Mat2{{0.5, 0.1}, {0.1, 0.2}}}};
  const CrlbResult r = network_crlb(net);
  ASSERT_TRUE(r.localizable);
  EXPECT_MATRIX_NEAR(r.per_agent[0], (Mat2{{0.5, 0.1}, {0.1, 0.2}}), 1e-12);
}

TEST(Crlb, SingleAnchorNetworkIsNotLocalizable) {
  const std::vector<Vec2> truth = {Vec2(0.0, 0.0), Vec2(3.0, 4.0)};
  const CrlbResult r = range_network_crlb(truth, {true, false}, {{1, 0, 0.1}, {0, 1, 0.1}});
  EXPECT_FALSE(r.localizable);
  EXPECT_TRUE(std::isinf(r.per_agent_rmse_m[1]));
  EXPECT_TRUE(std::isinf(r.network_rmse_m));
}

TEST(Crlb, AnchorFreeNetworkIsNotLocalizable) {
  const std::vector<Vec2> truth = {Vec2(0.0, 0.0), Vec2(3.0, 4.0), Vec2(5.0, -1.0)};
  const CrlbResult r = range_network_crlb(truth, {false, false, false},
                                          mutual_range_observations(truth, {false, false, false}, 0.1));
  EXPECT_FALSE(r.localizable);
  for (double v : r.per_agent_rmse_m) EXPECT_TRUE(std::isinf(v));
}

TEST(Crlb, DanglingAgentIsUnboundedWhileTheRestKeepTheirBound) {
  // Agent 3 is rigidly placed by three anchors; agent 4 only ranges to agent 3 (can rotate about it).
  const std::vector<Vec2> truth = {Vec2(0.0, 0.0), Vec2(10.0, 0.0), Vec2(0.0, 10.0), Vec2(4.0, 3.0),
                                   Vec2(7.0, 8.0)};
  const std::vector<bool> anchor = {true, true, true, false, false};
  std::vector<RangeObservation> base = {{3, 0, 0.1}, {3, 1, 0.1}, {3, 2, 0.1}};
  std::vector<RangeObservation> with_dangling = base;
  with_dangling.push_back({4, 3, 0.1});
  const CrlbResult r = range_network_crlb(truth, anchor, with_dangling);
  EXPECT_FALSE(r.localizable);
  EXPECT_TRUE(std::isinf(r.per_agent_rmse_m[4]));
  ASSERT_TRUE(std::isfinite(r.per_agent_rmse_m[3]));
  // The dangling range carries no information about agent 3 (agent 4's radial coordinate absorbs it).
  const CrlbResult alone = range_network_crlb(truth, anchor, base);
  EXPECT_MATRIX_NEAR(r.per_agent[3], alone.per_agent[3], 1e-9);
}

TEST(Crlb, RejectsInvalidInput) {
  EXPECT_THROW((void)range_network_crlb(kTruth, kAnchor, {{2, 7, 0.5}}), std::invalid_argument);
  EXPECT_THROW((void)range_network_crlb(kTruth, kAnchor, {{2, 0, 0.0}}), std::invalid_argument);
  EXPECT_THROW((void)range_network_crlb(kTruth, {true}, {}), std::invalid_argument);
}

TEST(Crlb, HandlesThreeHundredAgentsFullyConnected) {
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> uniform(0.0, 30.0);
  std::vector<Vec2> truth;
  std::vector<bool> anchor;
  for (int i = 0; i < 300; ++i) {
    truth.emplace_back(uniform(rng), uniform(rng));
    anchor.push_back(i < 75);
  }
  const auto start = std::chrono::steady_clock::now();
  const CrlbResult r =
      range_network_crlb(truth, anchor, mutual_range_observations(truth, anchor, 0.1), 100.0);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("[crlb] N=300 (225 unknowns, all pairs) in %.3f s, network bound %.5f m\n", seconds,
              r.network_rmse_m);
  EXPECT_TRUE(r.localizable);
  EXPECT_GT(r.network_rmse_m, 0.0);
  EXPECT_LT(r.network_rmse_m, 0.01);
}

}  // namespace
}  // namespace swarmloc::estimators
