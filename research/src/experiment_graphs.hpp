#pragma once
// Random sensor graphs of the Atanasov et al. experiments (relative_localization.cpp, dle_experiments.cpp).
// Internal to the experiments.
#include <random>
#include <vector>

#include "swarmloc/core/types.hpp"
#include "sync_bus.hpp"

namespace swarmloc::research::detail {

struct Edge {
  int i = 0;
  int j = 0;
};

struct Graph {
  std::vector<Vec2> positions;
  std::vector<Edge> edges;
  Adjacency adjacency;
  double radius_m = 0.0;
};

inline Vec2 normal2(std::mt19937_64& rng, double std_dev) {
  std::normal_distribution<double> n(0.0, std_dev);
  const double x = n(rng);
  return Vec2(x, n(rng));
}

inline std::vector<Vec2> uniform_points(int n, double side_m, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, side_m);
  std::vector<Vec2> points(static_cast<std::size_t>(n));
  for (auto& p : points) {
    const double x = u(rng);
    p = Vec2(x, u(rng));
  }
  return points;
}

inline Graph make_graph(const std::vector<Vec2>& points, double radius_m) {
  Graph g;
  g.positions = points;
  g.radius_m = radius_m;
  g.adjacency.assign(points.size(), {});
  for (std::size_t i = 0; i < points.size(); ++i) {
    for (std::size_t j = i + 1; j < points.size(); ++j) {
      if ((points[i] - points[j]).norm() <= radius_m) {
        g.edges.push_back(Edge{static_cast<int>(i), static_cast<int>(j)});
        g.adjacency[i].push_back(static_cast<int>(j));
        g.adjacency[j].push_back(static_cast<int>(i));
      }
    }
  }
  return g;
}

}  // namespace swarmloc::research::detail
