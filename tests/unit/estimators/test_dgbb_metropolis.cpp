#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "swarmloc/estimators/consensus/metropolis.hpp"

namespace swarmloc::estimators::consensus {
namespace {

std::vector<std::vector<int>> random_graph(int n, double p, std::mt19937_64& rng) {
  std::bernoulli_distribution edge(p);
  std::vector<std::vector<int>> adjacency(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      if (edge(rng)) {
        adjacency[static_cast<std::size_t>(i)].push_back(j);
        adjacency[static_cast<std::size_t>(j)].push_back(i);
      }
    }
  }
  return adjacency;
}

TEST(Metropolis, WeightsAreSymmetricDoublyStochasticWithPositiveDiagonalOnRandomGraphs) {
  std::mt19937_64 rng(11);
  for (int trial = 0; trial < 50; ++trial) {
    const auto adjacency = random_graph(5 + trial % 25, 0.05 + 0.02 * (trial % 20), rng);
    const MatX W = metropolis_matrix(adjacency);
    const auto n = W.rows();
    EXPECT_LT((W - W.transpose()).cwiseAbs().maxCoeff(), 1e-15);
    EXPECT_LT((W.rowwise().sum() - VecX::Ones(n)).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((W.colwise().sum().transpose() - VecX::Ones(n)).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_GT(W.diagonal().minCoeff(), 0.0);
    EXPECT_GE(W.minCoeff(), 0.0);
  }
}

TEST(Metropolis, LocalRowMatchesTheMatrix) {
  std::mt19937_64 rng(3);
  const auto adjacency = random_graph(12, 0.3, rng);
  const MatX W = metropolis_matrix(adjacency);
  for (std::size_t i = 0; i < adjacency.size(); ++i) {
    std::vector<int> degrees;
    for (const int j : adjacency[i])
      degrees.push_back(static_cast<int>(adjacency[static_cast<std::size_t>(j)].size()));
    const LocalWeights row = metropolis_weights(static_cast<int>(adjacency[i].size()), degrees);
    EXPECT_NEAR(row.self, W(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(i)), 1e-15);
    for (std::size_t k = 0; k < degrees.size(); ++k) {
      EXPECT_NEAR(row.neighbours[k], W(static_cast<Eigen::Index>(i), adjacency[i][k]), 1e-15);
    }
  }
}

TEST(Metropolis, PrintedRuleGivesZeroDiagonalOnARegularGraph) {  // [E-2]
  // A 6-cycle: every node has degree 2, so 1/max(2, 2) twice leaves W_ii = 0.
  std::vector<std::vector<int>> cycle(6);
  for (int i = 0; i < 6; ++i) {
    cycle[static_cast<std::size_t>(i)] = {(i + 5) % 6, (i + 1) % 6};
  }
  EXPECT_NEAR(metropolis_matrix(cycle, MetropolisRule::kPrinted).diagonal().maxCoeff(), 0.0, 1e-15);
  EXPECT_NEAR(metropolis_matrix(cycle).diagonal().minCoeff(), 1.0 / 3.0, 1e-15);
}

}  // namespace
}  // namespace swarmloc::estimators::consensus
