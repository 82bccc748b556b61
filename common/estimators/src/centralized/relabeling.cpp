#include "swarmloc/estimators/centralized/relabeling.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <cstdlib>
#include <numeric>
#include <queue>
#include <stdexcept>

namespace swarmloc::estimators::centralized {
namespace {

std::vector<std::vector<int>> adjacency(int num_agents, const std::vector<Edge>& edges) {
  std::vector<std::vector<int>> adj(static_cast<std::size_t>(num_agents));
  for (const auto& [i, j] : edges) {
    adj[static_cast<std::size_t>(i)].push_back(j);
    adj[static_cast<std::size_t>(j)].push_back(i);
  }
  return adj;
}

std::vector<int> labels_from_order(const std::vector<int>& order) {
  std::vector<int> labels(order.size());
  for (std::size_t rank = 0; rank < order.size(); ++rank) {
    labels[static_cast<std::size_t>(order[rank])] = static_cast<int>(rank);
  }
  return labels;
}

}  // namespace

std::vector<int> identity_labels(int num_agents) {
  std::vector<int> labels(static_cast<std::size_t>(num_agents));
  std::iota(labels.begin(), labels.end(), 0);
  return labels;
}

// Khan et al. Alg. 3.
std::vector<int> lexicographic_labels(const std::vector<Vec2>& positions) {
  std::vector<int> order = identity_labels(static_cast<int>(positions.size()));
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    const Vec2& pa = positions[static_cast<std::size_t>(a)];
    const Vec2& pb = positions[static_cast<std::size_t>(b)];
    return pa.x() < pb.x() || (pa.x() == pb.x() && pa.y() < pb.y());
  });
  return labels_from_order(order);
}

std::vector<int> reverse_cuthill_mckee_labels(int num_agents, const std::vector<Edge>& edges) {
  auto adj = adjacency(num_agents, edges);
  auto degree = [&](int v) { return adj[static_cast<std::size_t>(v)].size(); };
  for (auto& neighbours : adj) {
    std::sort(neighbours.begin(), neighbours.end(),
              [&](int a, int b) { return degree(a) < degree(b) || (degree(a) == degree(b) && a < b); });
  }
  std::vector<int> by_degree = identity_labels(num_agents);
  std::stable_sort(by_degree.begin(), by_degree.end(), [&](int a, int b) { return degree(a) < degree(b); });
  std::vector<bool> visited(static_cast<std::size_t>(num_agents), false);
  std::vector<int> order;
  order.reserve(static_cast<std::size_t>(num_agents));
  for (int seed : by_degree) {
    if (visited[static_cast<std::size_t>(seed)]) continue;
    std::queue<int> queue;
    queue.push(seed);
    visited[static_cast<std::size_t>(seed)] = true;
    while (!queue.empty()) {
      const int v = queue.front();
      queue.pop();
      order.push_back(v);
      for (int w : adj[static_cast<std::size_t>(v)]) {
        if (!visited[static_cast<std::size_t>(w)]) {
          visited[static_cast<std::size_t>(w)] = true;
          queue.push(w);
        }
      }
    }
  }
  std::reverse(order.begin(), order.end());
  return labels_from_order(order);
}

std::vector<int> inverse_labels(const std::vector<int>& labels) {
  std::vector<int> inverse(labels.size(), -1);
  for (std::size_t i = 0; i < labels.size(); ++i) {
    const int l = labels[i];
    if (l < 0 || static_cast<std::size_t>(l) >= labels.size() || inverse[static_cast<std::size_t>(l)] != -1) {
      throw std::invalid_argument("labels: not a permutation of 0 … N−1");
    }
    inverse[static_cast<std::size_t>(l)] = static_cast<int>(i);
  }
  return inverse;
}

int graph_bandwidth(const std::vector<Edge>& edges, const std::vector<int>& labels) {
  int beta = 0;
  for (const auto& [i, j] : edges) {
    beta =
        std::max(beta, std::abs(labels[static_cast<std::size_t>(i)] - labels[static_cast<std::size_t>(j)]));
  }
  return beta;
}

std::vector<Edge> disk_graph_edges(const std::vector<Vec2>& positions, double radius) {
  std::vector<Edge> edges;
  const int n = static_cast<int>(positions.size());
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      if ((positions[static_cast<std::size_t>(i)] - positions[static_cast<std::size_t>(j)]).norm() <=
          radius) {
        edges.emplace_back(i, j);
      }
    }
  }
  return edges;
}

bool is_connected(int num_agents, const std::vector<Edge>& edges) {
  if (num_agents <= 1) return true;
  const auto adj = adjacency(num_agents, edges);
  std::vector<bool> seen(static_cast<std::size_t>(num_agents), false);
  std::vector<int> stack{0};
  seen[0] = true;
  int count = 1;
  while (!stack.empty()) {
    const int v = stack.back();
    stack.pop_back();
    for (int w : adj[static_cast<std::size_t>(v)]) {
      if (!seen[static_cast<std::size_t>(w)]) {
        seen[static_cast<std::size_t>(w)] = true;
        ++count;
        stack.push_back(w);
      }
    }
  }
  return count == num_agents;
}

bool is_rigid(const std::vector<Vec2>& positions, const std::vector<Edge>& edges) {
  const int n = static_cast<int>(positions.size());
  if (n <= 1) return true;
  if (n == 2) return !edges.empty();
  MatX rigidity = MatX::Zero(static_cast<Eigen::Index>(edges.size()), 2 * n);
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const auto [i, j] = edges[e];
    const Vec2 delta = positions[static_cast<std::size_t>(i)] - positions[static_cast<std::size_t>(j)];
    const auto row = static_cast<Eigen::Index>(e);
    rigidity.block<1, 2>(row, 2 * i) = delta.transpose();
    rigidity.block<1, 2>(row, 2 * j) = -delta.transpose();
  }
  Eigen::ColPivHouseholderQR<MatX> qr(rigidity);
  qr.setThreshold(1e-9);
  return qr.rank() == 2 * n - 3;
}

}  // namespace swarmloc::estimators::centralized
