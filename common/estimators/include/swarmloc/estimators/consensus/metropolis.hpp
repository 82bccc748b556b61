#pragma once
// Metropolis consensus weights (docs/algorithms.md §1.2, [E-2]). Each node needs only its own degree and its
// neighbours' degrees.
#include <map>
#include <span>
#include <vector>

#include "swarmloc/core/types.hpp"

namespace swarmloc::estimators::consensus {

enum class MetropolisRule {
  kPlusOne,  ///< W_ij = 1/(1 + max(|N_i|, |N_j|)) (default, [E-2]): W_ii > 0 always
  kPrinted,  ///< W_ij = 1/max(|N_i|, |N_j|) as printed in Calafiore et al. (W_ii can be 0)
};

/// W_ij for an edge between nodes of degree `degree_i` and `degree_j` (both ≥ 1).
double metropolis_edge_weight(int degree_i, int degree_j, MetropolisRule rule = MetropolisRule::kPlusOne);

/// Row i of W: the weight of each neighbour (same order as `neighbour_degrees`) and W_ii = 1 − Σ_j W_ij.
struct LocalWeights {
  double self = 1.0;
  std::vector<double> neighbours;
};
LocalWeights metropolis_weights(int own_degree, std::span<const int> neighbour_degrees,
                                MetropolisRule rule = MetropolisRule::kPlusOne);

/// Degrees known to one node: its own and its neighbours' (from their STATE messages).
struct ConsensusDegrees {
  int own = 0;
  std::map<AgentId, int> neighbours;
};

/// The full n×n matrix for an undirected graph given as adjacency lists (a test and experiment helper).
MatX metropolis_matrix(const std::vector<std::vector<int>>& adjacency,
                       MetropolisRule rule = MetropolisRule::kPlusOne);

}  // namespace swarmloc::estimators::consensus
