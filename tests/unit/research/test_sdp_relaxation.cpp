#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "swarmloc/research/sdp_relaxation.hpp"

namespace swarmloc::research {
namespace {

struct Instance {
  std::vector<Vec2> truth;
  gradient::RangeProblem problem;
};

// Anchors at the corners of [0, 1]², `sensors` unknowns drawn uniformly inside, every pair within `radius`
// measured with std ν_d·d (Calafiore et al. eq. (16)); `radius` ≥ √2 gives the complete graph.
Instance make_instance(int sensors, double radius, double noise_factor, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0.05, 0.95);
  std::normal_distribution<double> normal(0.0, 1.0);
  Instance instance;
  instance.truth = {Vec2(0, 0), Vec2(1, 0), Vec2(0, 1), Vec2(1, 1)};
  for (int k = 0; k < sensors; ++k) {
    const double x = uniform(rng);
    instance.truth.emplace_back(x, uniform(rng));
  }
  const std::size_t n = instance.truth.size();
  instance.problem.anchor.assign(n, false);
  instance.problem.initial.assign(n, Vec2::Zero());
  for (std::size_t a = 0; a < 4; ++a) {
    instance.problem.anchor[a] = true;
    instance.problem.initial[a] = instance.truth[a];
  }
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      const double d = (instance.truth[i] - instance.truth[j]).norm();
      if (d >= radius) continue;
      const double noisy = std::abs(d + noise_factor * d * normal(rng));
      instance.problem.edges.push_back({static_cast<int>(i), static_cast<int>(j), noisy});
    }
  }
  return instance;
}

Eigen::MatrixXd gram_of(const std::vector<Vec2>& positions, const std::vector<int>& unknown_index) {
  int n_u = 0;
  for (const int u : unknown_index) n_u += u >= 0 ? 1 : 0;
  Eigen::Matrix2Xd X(2, n_u);
  for (std::size_t i = 0; i < unknown_index.size(); ++i) {
    if (unknown_index[i] >= 0) X.col(unknown_index[i]) = positions[i];
  }
  return X.transpose() * X;
}

// Complete graph, 4 non-collinear anchors, exact ranges: strongly localizable (So–Ye), so the relaxation is
// tight with a unique rank-2 solution Y = XᵀX and zero slack. Tolerance: SDPA stops at a relative gap of
// 1e−7 (epsilonStar); for this well-conditioned instance the central-path point is within ~1e−6 of the
// solution (measured max error ~1e−7), 1e−4 leaves room without hiding a wrong constraint (which moves
// nodes by centimetres or more, see the mutation note in docs/reproduction.md).
TEST(SdpRelaxation, RecoversEveryPositionOfANoiseFreeUniquelyLocalizableNetwork) {
  const Instance instance = make_instance(8, 2.0, 0.0, 11);
  const SdpRelaxationResult r = solve_sdp_relaxation(instance.problem);
  ASSERT_EQ(r.status, SdpStatus::kOptimal) << r.solver_phase;
  ASSERT_EQ(r.positions.size(), instance.truth.size());
  EXPECT_EQ(r.anchor_sensor_edges, 4 * 8);
  EXPECT_EQ(r.sensor_sensor_edges, 8 * 7 / 2);
  for (std::size_t i = 0; i < instance.truth.size(); ++i)
    EXPECT_LT((r.positions[i] - instance.truth[i]).norm(), 1e-4) << "node " << i;
  EXPECT_LT(r.total_slack, 1e-5);
  EXPECT_LT(r.max_residual, 1e-6);
  // Tight relaxation: Y = XᵀX.
  EXPECT_LT((r.gram - gram_of(r.positions, r.unknown_index)).cwiseAbs().maxCoeff(), 1e-4);
}

TEST(SdpRelaxation, NoiseFreeSparseGeometricGraphIsAlsoRecovered) {
  const Instance instance = make_instance(12, 0.65, 0.0, 5);
  const SdpRelaxationResult r = solve_sdp_relaxation(instance.problem);
  ASSERT_TRUE(r.usable()) << r.solver_phase;
  for (std::size_t i = 0; i < instance.truth.size(); ++i)
    EXPECT_LT((r.positions[i] - instance.truth[i]).norm(), 1e-3) << "node " << i;
  EXPECT_LT(r.total_slack, 1e-5);
}

// A minimizer's objective is ≤ the objective of every feasible point, in particular (X, Y) = (truth, XᵀX)
// with the best slacks; and the reported objective equals the objective recomputed from the returned (X, Y)
// with the constraint written independently of the SDPA encoding.
TEST(SdpRelaxation, ObjectiveAtTheSolutionIsAtMostTheObjectiveAtTheTruth) {
  for (const std::uint64_t seed : {1, 2, 3}) {
    const Instance instance = make_instance(10, 0.8, 0.1, seed);
    const SdpRelaxationResult r = solve_sdp_relaxation(instance.problem);
    ASSERT_TRUE(r.usable()) << r.solver_phase;
    const std::vector<int> index = sdp_unknown_index(instance.problem);
    const double at_truth =
        sdp_relaxation_objective(instance.problem, instance.truth, gram_of(instance.truth, index), index);
    EXPECT_GT(at_truth, 1e-3) << "noise must make the truth infeasible without slack";
    EXPECT_LE(r.total_slack, at_truth * (1.0 + 1e-6) + 1e-9) << "seed " << seed;
    const double recomputed =
        sdp_relaxation_objective(instance.problem, r.positions, r.gram, r.unknown_index);
    EXPECT_NEAR(recomputed, r.total_slack, 1e-5 * (1.0 + r.total_slack)) << "seed " << seed;
    EXPECT_LT(r.max_residual, 1e-6);
  }
}

TEST(SdpRelaxation, AnchorsKeepTheirPositionsAndAnchorOnlyEdgesAreSkipped) {
  Instance instance = make_instance(5, 2.0, 0.05, 4);
  const SdpRelaxationResult r = solve_sdp_relaxation(instance.problem);
  ASSERT_TRUE(r.usable());
  for (std::size_t a = 0; a < 4; ++a) EXPECT_EQ(r.positions[a], instance.truth[a]);
  EXPECT_EQ(r.anchor_sensor_edges + r.sensor_sensor_edges,
            static_cast<int>(instance.problem.edges.size()) - 6);
}

TEST(SdpRelaxation, SolverPrintsNothing) {
  const Instance instance = make_instance(6, 2.0, 0.05, 9);
  ::testing::internal::CaptureStdout();
  ::testing::internal::CaptureStderr();
  const SdpRelaxationResult r = solve_sdp_relaxation(instance.problem);
  const std::string out = ::testing::internal::GetCapturedStdout();
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_TRUE(r.usable());
  EXPECT_EQ(out, "");
  EXPECT_EQ(err, "");
}

TEST(SdpRelaxation, MalformedProblemsThrowAndDegenerateOnesReturn) {
  Instance instance = make_instance(3, 2.0, 0.0, 2);
  gradient::RangeProblem bad = instance.problem;
  bad.edges.push_back({4, 4, 1.0});
  EXPECT_THROW(solve_sdp_relaxation(bad), std::invalid_argument);
  bad = instance.problem;
  bad.edges.push_back({0, 99, 1.0});
  EXPECT_THROW(solve_sdp_relaxation(bad), std::invalid_argument);
  bad = instance.problem;
  bad.edges.push_back({0, 5, std::nan("")});
  EXPECT_THROW(solve_sdp_relaxation(bad), std::invalid_argument);
  SdpRelaxationParams params;
  params.epsilon = 0.0;
  EXPECT_THROW(solve_sdp_relaxation(instance.problem, params), std::invalid_argument);
  gradient::RangeProblem anchors_only;
  anchors_only.anchor = {true, true};
  anchors_only.initial = {Vec2(0, 0), Vec2(1, 0)};
  anchors_only.edges = {{0, 1, 1.0}};
  const SdpRelaxationResult r = solve_sdp_relaxation(anchors_only);
  EXPECT_EQ(r.status, SdpStatus::kOptimal);
  EXPECT_EQ(r.positions.size(), 2U);
}

// Unknowns without ranges, or with too few, leave the relaxation underdetermined: SDPA still returns (the
// analytic centre of the optimal face), never exits the process.
TEST(SdpRelaxation, UnderdeterminedProblemsReturnAStatus) {
  gradient::RangeProblem problem;
  problem.anchor = {true, true, false};
  problem.initial = {Vec2(0, 0), Vec2(1, 0), Vec2(5, 5)};
  for (const std::vector<gradient::RangeEdge>& edges :
       {std::vector<gradient::RangeEdge>{}, std::vector<gradient::RangeEdge>{{0, 2, 0.5}},
        std::vector<gradient::RangeEdge>{{0, 1, 1.0}}}) {
    problem.edges = edges;
    const SdpRelaxationResult r = solve_sdp_relaxation(problem);
    EXPECT_TRUE(r.usable()) << r.solver_phase;
    ASSERT_EQ(r.positions.size(), 3U);
    EXPECT_TRUE(r.positions[2].allFinite());
    EXPECT_EQ(r.positions[0], Vec2(0, 0));
  }
}

}  // namespace
}  // namespace swarmloc::research
