#include "swarmloc/estimators/consensus/metropolis.hpp"

#include <algorithm>
#include <cstddef>
#include <stdexcept>

namespace swarmloc::estimators::consensus {

double metropolis_edge_weight(int degree_i, int degree_j, MetropolisRule rule) {
  if (degree_i < 1 || degree_j < 1)
    throw std::invalid_argument("metropolis: degrees of an edge must be >= 1");
  const int max_degree = std::max(degree_i, degree_j);
  // docs/algorithms.md §1.2 with the [E-2] "+1"; the printed rule is 1/max.
  return rule == MetropolisRule::kPlusOne ? 1.0 / (1.0 + max_degree) : 1.0 / max_degree;
}

LocalWeights metropolis_weights(int own_degree, std::span<const int> neighbour_degrees, MetropolisRule rule) {
  LocalWeights weights;
  weights.neighbours.reserve(neighbour_degrees.size());
  double sum = 0.0;
  for (const int degree : neighbour_degrees) {
    const double w = metropolis_edge_weight(own_degree, degree, rule);
    weights.neighbours.push_back(w);
    sum += w;
  }
  weights.self = 1.0 - sum;
  return weights;
}

MatX metropolis_matrix(const std::vector<std::vector<int>>& adjacency, MetropolisRule rule) {
  const auto n = static_cast<Eigen::Index>(adjacency.size());
  MatX W = MatX::Zero(n, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& row = adjacency[static_cast<std::size_t>(i)];
    const int degree_i = static_cast<int>(row.size());
    double sum = 0.0;
    for (const int j : row) {
      const int degree_j = static_cast<int>(adjacency[static_cast<std::size_t>(j)].size());
      const double w = metropolis_edge_weight(degree_i, degree_j, rule);
      W(i, j) = w;
      sum += w;
    }
    W(i, i) = 1.0 - sum;
  }
  return W;
}

}  // namespace swarmloc::estimators::consensus
