// Vertex relabeling, graph bandwidth, Lemma 1 and Theorem 1 (Khan et al. Alg. 3, eqs. (18)–(19);
// docs/algorithms.md §2.5).
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "swarmloc/estimators/centralized/band_matrix.hpp"
#include "swarmloc/estimators/centralized/centralized_filter.hpp"
#include "swarmloc/estimators/centralized/relabeling.hpp"
#include "swarmloc/research/centralized_experiments.hpp"

namespace swarmloc::research {
namespace {

std::vector<Vec2> random_positions(int count, double side, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, side);
  std::vector<Vec2> positions;
  for (int i = 0; i < count; ++i) positions.emplace_back(u(rng), u(rng));
  return positions;
}

TEST(Relabeling, LexicographicSortsByXThenY) {
  const std::vector<Vec2> positions{{2.0, 0.0}, {1.0, 5.0}, {1.0, 3.0}, {0.0, 9.0}};
  EXPECT_EQ(centralized::lexicographic_labels(positions), (std::vector<int>{3, 2, 1, 0}));
  EXPECT_EQ(centralized::inverse_labels(centralized::lexicographic_labels(positions)),
            (std::vector<int>{3, 2, 1, 0}));
}

// Fig. 1: a k×k unit grid with r = 1 gets bandwidth k, its minimum.
TEST(Relabeling, GridGetsMinimalBandwidth) {
  for (int k : {3, 4, 6}) {
    std::vector<Vec2> positions;
    std::mt19937_64 rng(k);
    for (int i = 0; i < k; ++i) {
      for (int j = 0; j < k; ++j) positions.emplace_back(j, i);  // generation order: row by row
    }
    std::shuffle(positions.begin(), positions.end(), rng);
    const auto edges = centralized::disk_graph_edges(positions, 1.0);
    EXPECT_EQ(centralized::graph_bandwidth(edges, centralized::lexicographic_labels(positions)), k);
  }
}

TEST(Relabeling, InverseLabelsRejectsNonPermutation) {
  EXPECT_THROW(centralized::inverse_labels({0, 2, 2}), std::invalid_argument);
  EXPECT_THROW(centralized::inverse_labels({0, 3, 1}), std::invalid_argument);
}

TEST(Relabeling, ReverseCuthillMcKeeRecoversAShuffledPath) {
  std::vector<int> order = centralized::identity_labels(20);
  std::mt19937_64 rng(3);
  std::shuffle(order.begin(), order.end(), rng);
  std::vector<centralized::Edge> edges;
  for (int i = 0; i + 1 < 20; ++i) edges.emplace_back(order[i], order[i + 1]);
  EXPECT_GT(centralized::graph_bandwidth(edges, centralized::identity_labels(20)), 1);
  const auto labels = centralized::reverse_cuthill_mckee_labels(20, edges);
  EXPECT_NO_THROW(centralized::inverse_labels(labels));
  EXPECT_EQ(centralized::graph_bandwidth(edges, labels), 1);
}

// Lemma 1 / eq. (18) with: Bandwidth(S_k) = d(β + 1) − 1 under any labeling.
TEST(Relabeling, MeasurementInformationBandwidthFollowsLemma1) {
  std::mt19937_64 rng(4);
  for (int trial = 0; trial < 10; ++trial) {
    const auto positions = random_positions(40, 60.0, rng);
    const auto edges = centralized::disk_graph_edges(positions, 15.0);
    ASSERT_FALSE(edges.empty());
    centralized::CentralizedMeasurements m;
    for (int b = 0; b < 40; b += 5) m.beacon_fixes.emplace_back(b, positions[static_cast<std::size_t>(b)]);
    for (const auto& [i, j] : edges) m.ranges.push_back({i, j, 1.0});
    VecX x(80);
    for (int a = 0; a < 40; ++a) x.segment<2>(2 * a) = positions[static_cast<std::size_t>(a)];
    std::vector<int> random = centralized::identity_labels(40);
    std::shuffle(random.begin(), random.end(), rng);
    for (const auto& labels : {centralized::identity_labels(40), centralized::lexicographic_labels(positions),
                               random, centralized::reverse_cuthill_mckee_labels(40, edges)}) {
      const MatX s = centralized::assemble_measurement_information(m, x, labels).information;
      EXPECT_EQ(centralized::matrix_bandwidth(s),
                centralized::measurement_bandwidth(centralized::graph_bandwidth(edges, labels)));
    }
  }
}

// Theorem 1 (tight form of eq. (25)): β_VR <= max_i |X ∩ [x_i, x_i + r] × R| − 1 <= φ_max − 1.
TEST(Relabeling, VertexRelabelingBandwidthObeysTheorem1) {
  std::mt19937_64 rng(5);
  for (int trial = 0; trial < 20; ++trial) {
    const auto positions = random_positions(30 + 10 * trial, 40.0 + 5.0 * trial, rng);
    const auto edges = centralized::disk_graph_edges(positions, 15.0);
    std::vector<double> xs;
    for (const Vec2& p : positions) xs.push_back(p.x());
    std::sort(xs.begin(), xs.end());
    EXPECT_LE(centralized::graph_bandwidth(edges, centralized::lexicographic_labels(positions)),
              max_strip_count(xs, 15.0) - 1);
  }
}

TEST(VrBandwidthBound, MaxStripCountScansAllWindows) {
  EXPECT_EQ(max_strip_count({}, 1.0), 0);
  EXPECT_EQ(max_strip_count({0.0, 0.5, 1.0, 1.6, 1.7, 1.8, 5.0}, 1.0), 4);
  EXPECT_EQ(max_strip_count({0.0, 2.0, 4.0}, 1.0), 1);
}

// E-A3 (Sec. 5.3, Fig. 7): the bound grows sublinearly; at λ = 0.01, |V| ≈ 10⁴ it is below 3 % of |V|.
TEST(VrBandwidthBound, IsSublinearInTheNumberOfAgents) {
  std::mt19937_64 rng(6);
  for (int trial = 0; trial < 5; ++trial) {
    const VrBoundSample large = vr_bandwidth_bound(0.01, 1000.0, 15.0, rng);
    EXPECT_NEAR(large.num_agents, 10000, 500);
    EXPECT_LT(large.phi_max, 0.03 * large.num_agents) << "phi_max " << large.phi_max;
    EXPECT_GT(large.phi_max, 0.01 * 1000.0 * 15.0);  // eq. (35) mean λ l r, exceeded by the max
  }
}

}  // namespace
}  // namespace swarmloc::research
