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

// ---- 3-D networks (World::dimensions == 3) ----

/// The ranges of `network`, as a function of θ (the non-anchors' (x, y, z) in index order).
VecX ranges3_at(const RangeNetwork3& network, const VecX& theta) {
  std::vector<Vec3> x = network.truth;
  Eigen::Index next = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (!network.is_anchor[i]) x[i] = theta.segment<3>(next), next += 3;
  }
  VecX out(static_cast<Eigen::Index>(network.ranges.size()));
  for (std::size_t m = 0; m < network.ranges.size(); ++m) {
    const auto& r = network.ranges[m];
    out(static_cast<Eigen::Index>(m)) =
        (x[static_cast<std::size_t>(r.a)] - x[static_cast<std::size_t>(r.b)]).norm();
  }
  return out;
}

TEST(Crlb3, FisherEqualsTheFiniteDifferenceJacobians) {
  // Anchors at several heights, three unknowns; every pair measured from both ends, σ varying per link.
  RangeNetwork3 network;
  network.truth = {Vec3(0.0, 0.0, 0.0), Vec3(20.0, 0.0, 5.0), Vec3(0.0, 20.0, 10.0), Vec3(20.0, 20.0, 2.0),
                   Vec3(6.0, 7.0, 3.0), Vec3(13.0, 5.0, 8.0), Vec3(9.0, 15.0, 1.0)};
  network.is_anchor = {true, true, true, true, false, false, false};
  for (AgentId a = 0; a < 7; ++a) {
    for (AgentId b = 0; b < 7; ++b) {
      if (a != b && !(a < 4 && b < 4)) network.ranges.push_back({a, b, 0.05 + 0.01 * (a + 2 * b)});
    }
  }
  VecX theta(9);
  theta << network.truth[4], network.truth[5], network.truth[6];
  // H by central differences of the range function; J = Σ HᵀH/σ² = Hᵀ R⁻¹ H.
  constexpr double kStep = 1e-6;
  const auto rows = static_cast<Eigen::Index>(network.ranges.size());
  MatX H(rows, 9);
  for (Eigen::Index k = 0; k < 9; ++k) {
    VecX plus = theta, minus = theta;
    plus(k) += kStep;
    minus(k) -= kStep;
    H.col(k) = (ranges3_at(network, plus) - ranges3_at(network, minus)) / (2.0 * kStep);
  }
  VecX weight(rows);
  for (Eigen::Index m = 0; m < rows; ++m) {
    const double s = network.ranges[static_cast<std::size_t>(m)].std_m;
    weight(m) = 1.0 / (s * s);
  }
  const MatX expected = 3.0 * H.transpose() * weight.asDiagonal() * H;
  const MatX fisher = range_network_fisher(network, 3.0);
  ASSERT_EQ(fisher.rows(), 9);
  EXPECT_LT((fisher - expected).cwiseAbs().maxCoeff(), 1e-6 * expected.cwiseAbs().maxCoeff());
  // The CRB is the inverse of it, block by block; the network RMSE averages 3 coordinates per agent.
  const CrlbResult3 crlb = network_crlb(network, 3.0);
  const MatX crb = expected.inverse();
  ASSERT_TRUE(crlb.localizable);
  for (int i = 0; i < 3; ++i) {
    const Mat3 block = crb.block<3, 3>(3 * i, 3 * i);
    EXPECT_LT((crlb.per_agent[static_cast<std::size_t>(4 + i)] - block).cwiseAbs().maxCoeff(),
              1e-6 * block.cwiseAbs().maxCoeff());
  }
  EXPECT_NEAR(crlb.network_rmse_m, std::sqrt(crb.trace() / 3.0), 1e-6 * crlb.network_rmse_m);
}

TEST(Crlb3, OneUnknownAndFourAnchorsMatchHandArithmetic) {
  // Unknown at the origin; anchors on +x, +y, +z and −x: u = (∓1, 0, 0), (0, −1, 0), (0, 0, −1).
  // σ = 0.2: J = diag(2, 1, 1)/0.04 → CRB = diag(0.02, 0.04, 0.04), RMSE = sqrt(0.1).
  RangeNetwork3 network;
  network.truth = {Vec3(5.0, 0.0, 0.0), Vec3(0.0, 7.0, 0.0), Vec3(0.0, 0.0, 3.0), Vec3(-4.0, 0.0, 0.0),
                   Vec3::Zero()};
  network.is_anchor = {true, true, true, true, false};
  for (AgentId a = 0; a < 4; ++a) network.ranges.push_back({4, a, 0.2});
  const CrlbResult3 symmetric = network_crlb(network);
  ASSERT_TRUE(symmetric.localizable);
  EXPECT_LT(
      (symmetric.per_agent[4] - Vec3(0.02, 0.04, 0.04).asDiagonal().toDenseMatrix()).cwiseAbs().maxCoeff(),
      1e-15);
  EXPECT_NEAR(symmetric.network_rmse_m, std::sqrt(0.1), 1e-15);
  EXPECT_EQ(symmetric.per_agent_rmse_m[0], 0.0);  // a known anchor

  // A general placement: (HᵀR⁻¹H)⁻¹ with the unit vectors written out.
  network.truth = {Vec3(10.0, 1.0, 0.0), Vec3(-2.0, 9.0, 4.0), Vec3(1.0, -3.0, 12.0), Vec3(-6.0, -5.0, -1.0),
                   Vec3(1.0, 2.0, 3.0)};
  const std::vector<double> sigma = {0.1, 0.2, 0.3, 0.4};
  for (std::size_t m = 0; m < 4; ++m) network.ranges[m].std_m = sigma[m];
  Eigen::Matrix<double, 4, 3> H;
  Eigen::Vector4d r_inverse;
  for (int m = 0; m < 4; ++m) {
    const Vec3 d = network.truth[4] - network.truth[static_cast<std::size_t>(m)];
    H.row(m) = d.transpose() / d.norm();
    r_inverse(m) = 1.0 / (sigma[static_cast<std::size_t>(m)] * sigma[static_cast<std::size_t>(m)]);
  }
  const Mat3 expected = (H.transpose() * r_inverse.asDiagonal() * H).inverse();
  const CrlbResult3 general = network_crlb(network);
  EXPECT_LT((general.per_agent[4] - expected).cwiseAbs().maxCoeff(), 1e-12 * expected.cwiseAbs().maxCoeff());
  EXPECT_NEAR(general.network_rmse_m, std::sqrt(expected.trace()), 1e-12);
}

TEST(Crlb3, AnchorsAndUnknownsInOnePlaneAreNotLocalizableAlongItsNormal) {
  // Every anchor and both unknowns at z = 2: the ranges' gradients lie in the plane, so J has a null
  // direction along z for each unknown (J is singular, per agent +inf).
  RangeNetwork3 network;
  network.truth = {Vec3(0.0, 0.0, 2.0),  Vec3(10.0, 0.0, 2.0), Vec3(10.0, 10.0, 2.0),
                   Vec3(0.0, 10.0, 2.0), Vec3(3.0, 4.0, 2.0),  Vec3(7.0, 6.0, 2.0)};
  network.is_anchor = {true, true, true, true, false, false};
  network.ranges = mutual_range_observations(std::vector<Vec2>(6, Vec2::Zero()), network.is_anchor, 0.1);
  const CrlbResult3 flat = network_crlb(network);
  EXPECT_FALSE(flat.localizable);
  EXPECT_TRUE(std::isinf(flat.network_rmse_m));
  EXPECT_TRUE(std::isinf(flat.per_agent_rmse_m[4]));
  EXPECT_TRUE(std::isinf(flat.per_agent_rmse_m[5]));
  // One anchor lifted out of the plane breaks the degeneracy: finite, and of the order of σ.
  network.truth[2].z() = 8.0;
  const CrlbResult3 lifted = network_crlb(network);
  EXPECT_TRUE(lifted.localizable);
  EXPECT_TRUE(std::isfinite(lifted.network_rmse_m));
  EXPECT_LT(lifted.network_rmse_m, 1.0);
}

}  // namespace
}  // namespace swarmloc::estimators
