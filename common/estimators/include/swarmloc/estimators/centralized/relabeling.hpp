#pragma once
// Vertex relabeling and graph bandwidth (Khan et al. Alg. 3, Lemma 1, Theorem 1; docs/algorithms.md §2.5).
// A labeling is a vector `labels` with labels[agent] = π(agent) ∈ {0, …, N−1}.
#include <utility>
#include <vector>

#include "swarmloc/core/types.hpp"

namespace swarmloc::estimators::centralized {

using Edge = std::pair<int, int>;

/// π(i) = i.
std::vector<int> identity_labels(int num_agents);
/// Khan et al. Alg. 3: π(i) = rank of x̃_i in the lexicographic order (x, then y). Ties keep input order.
std::vector<int> lexicographic_labels(const std::vector<Vec2>& positions);
/// Reverse Cuthill–McKee (per component, starting at a minimum-degree vertex), as labels.
std::vector<int> reverse_cuthill_mckee_labels(int num_agents, const std::vector<Edge>& edges);
/// inverse[π(i)] = i. Throws std::invalid_argument if `labels` is not a permutation.
std::vector<int> inverse_labels(const std::vector<int>& labels);

/// β = max over edges of |π(i) − π(j)| (0 without edges).
int graph_bandwidth(const std::vector<Edge>& edges, const std::vector<int>& labels);
/// Lemma 1 / eq. (18): Bandwidth(S) = d(β + 1) − 1 (for a graph with at least one edge).
constexpr int measurement_bandwidth(int graph_bandwidth, int dimension = 2) {
  return dimension * (graph_bandwidth + 1) - 1;
}

/// Edges (i < j) with ‖x_i − x_j‖ <= radius (docs/algorithms.md §1.2 disk graph). O(N²).
std::vector<Edge> disk_graph_edges(const std::vector<Vec2>& positions, double radius);
bool is_connected(int num_agents, const std::vector<Edge>& edges);
/// Infinitesimal rigidity in the plane at the given positions: rank(rigidity matrix) = 2N − 3.
bool is_rigid(const std::vector<Vec2>& positions, const std::vector<Edge>& edges);

}  // namespace swarmloc::estimators::centralized
