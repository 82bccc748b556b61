#include "swarmloc/sim/experiments/relative_localization.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <stdexcept>

#include "experiments/sync_bus.hpp"
#include "swarmloc/estimators/consensus/dle.hpp"
#include "swarmloc/estimators/consensus/jacobi.hpp"

namespace swarmloc::sim::experiments {
namespace {

using detail::Adjacency;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

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

Vec2 normal2(std::mt19937_64& rng, double std_dev) {
  std::normal_distribution<double> n(0.0, std_dev);
  const double x = n(rng);
  return Vec2(x, n(rng));
}

std::vector<Vec2> uniform_points(int n, double side_m, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, side_m);
  std::vector<Vec2> points(static_cast<std::size_t>(n));
  for (auto& p : points) {
    const double x = u(rng);
    p = Vec2(x, u(rng));
  }
  return points;
}

Graph make_graph(const std::vector<Vec2>& points, double radius_m) {
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

/// Uniform points; radius = the num_edges-th smallest pairwise distance (exactly num_edges edges, [C-5]).
Graph draw_graph_with_edges(const JacobiExperimentConfig& c, std::mt19937_64& rng, int& rejected) {
  for (int attempt = 0; attempt < c.max_graph_attempts; ++attempt) {
    const auto points = uniform_points(c.num_nodes, c.side_m, rng);
    std::vector<double> distances;
    for (std::size_t i = 0; i < points.size(); ++i) {
      for (std::size_t j = i + 1; j < points.size(); ++j) distances.push_back((points[i] - points[j]).norm());
    }
    const auto k = static_cast<std::size_t>(c.num_edges - 1);
    if (k >= distances.size()) throw std::invalid_argument("jacobi_experiment.num_edges: more than n(n-1)/2");
    std::nth_element(distances.begin(), distances.begin() + static_cast<std::ptrdiff_t>(k), distances.end());
    Graph g = make_graph(points, distances[k]);
    if (detail::connected(g.adjacency)) return g;
    ++rejected;
  }
  throw std::runtime_error("jacobi_experiment: no connected graph in max_graph_attempts draws");
}

/// Uniform points; num_edges distinct pairs drawn uniformly (G(n, m)), redrawn until connected.
Graph draw_gnm_graph(const JacobiExperimentConfig& c, std::mt19937_64& rng, int& rejected) {
  const auto n = static_cast<std::size_t>(c.num_nodes);
  if (static_cast<double>(c.num_edges) > 0.5 * static_cast<double>(n) * static_cast<double>(n - 1))
    throw std::invalid_argument("jacobi_experiment.num_edges: more than n(n-1)/2");
  std::uniform_int_distribution<int> pick(0, c.num_nodes - 1);
  for (int attempt = 0; attempt < c.max_graph_attempts; ++attempt) {
    Graph g;
    g.positions = uniform_points(c.num_nodes, c.side_m, rng);
    g.adjacency.assign(n, {});
    std::vector<bool> taken(n * n, false);
    while (g.edges.size() < static_cast<std::size_t>(c.num_edges)) {
      int a = pick(rng);
      int b = pick(rng);
      if (a == b) continue;
      if (a > b) std::swap(a, b);
      const std::size_t key = static_cast<std::size_t>(a) * n + static_cast<std::size_t>(b);
      if (taken[key]) continue;
      taken[key] = true;
      g.edges.push_back(Edge{a, b});
      g.adjacency[static_cast<std::size_t>(a)].push_back(b);
      g.adjacency[static_cast<std::size_t>(b)].push_back(a);
    }
    if (detail::connected(g.adjacency)) return g;
    ++rejected;
  }
  throw std::runtime_error("jacobi_experiment: no connected graph in max_graph_attempts draws");
}

}  // namespace

JacobiExperimentResult run_jacobi_experiment(const JacobiExperimentConfig& c) {
  if (c.num_nodes < 2 || c.steps < 1 || c.runs < 1)
    throw std::invalid_argument("jacobi_experiment: bad sizes");
  std::mt19937_64 rng(c.seed);
  const auto steps = static_cast<std::size_t>(c.steps);
  std::vector<double> se(steps + 1, 0.0);
  std::vector<double> blue_se(steps + 1, 0.0);
  std::vector<double> crb(steps + 1, 0.0);
  JacobiExperimentResult result;
  const int n = c.num_nodes;
  const int m = n - 1;  // unknowns: nodes 1…n−1
  const double var = c.measurement_std_m * c.measurement_std_m;
  for (int run = 0; run < c.runs; ++run) {
    const Graph g = c.graph_model == RelativeGraphModel::kGnm
                        ? draw_gnm_graph(c, rng, result.graphs_rejected)
                        : draw_graph_with_edges(c, rng, result.graphs_rejected);
    result.mean_radius_m += g.radius_m / c.runs;
    double length_sum = 0.0;
    for (const Edge& e : g.edges)
      length_sum +=
          (g.positions[static_cast<std::size_t>(e.i)] - g.positions[static_cast<std::size_t>(e.j)]).norm();
    result.mean_edge_length_m += length_sum / static_cast<double>(g.edges.size()) / c.runs;
    std::vector<Vec2> truth(g.positions.size());
    for (std::size_t i = 0; i < truth.size(); ++i)
      truth[i] = g.positions[i] - g.positions[0];  // node 0's frame
    std::vector<std::unique_ptr<estimators::Estimator>> agents;
    std::vector<const estimators::consensus::JacobiLocalization*> jacobi;
    for (int i = 0; i < n; ++i) {
      estimators::AgentSetup setup;
      setup.id = i;
      setup.anchor = i == 0;
      setup.initial_guess_m =
          i == 0 ? Vec2::Zero() : Vec2(truth[static_cast<std::size_t>(i)] + normal2(rng, c.prior_std_m));
      auto agent = std::make_unique<estimators::consensus::JacobiLocalization>(setup);
      jacobi.push_back(agent.get());
      agents.push_back(std::move(agent));
    }
    auto accumulate_error = [&](std::size_t t) {
      for (int i = 1; i < n; ++i) {
        se[t] +=
            (jacobi[static_cast<std::size_t>(i)]->mean() - truth[static_cast<std::size_t>(i)]).squaredNorm();
      }
    };
    accumulate_error(0);
    // BLUE normal matrix L̃ = (Laplacian ⊗ I₂)/σ² without node 0 (002 eq. (8)); one factorization per run.
    MatX L = MatX::Zero(2 * m, 2 * m);
    for (const Edge& e : g.edges) {
      const int a = e.i - 1;
      const int b = e.j - 1;
      if (a >= 0) L.block<2, 2>(2 * a, 2 * a) += Mat2::Identity() / var;
      if (b >= 0) L.block<2, 2>(2 * b, 2 * b) += Mat2::Identity() / var;
      if (a >= 0 && b >= 0) {
        L.block<2, 2>(2 * a, 2 * b) -= Mat2::Identity() / var;
        L.block<2, 2>(2 * b, 2 * a) -= Mat2::Identity() / var;
      }
    }
    const Eigen::LLT<MatX> llt(L);
    const double trace_inverse = llt.solve(MatX::Identity(2 * m, 2 * m)).trace();
    const double samples_per_step = c.shared_measurements ? 1.0 : 2.0;
    std::vector<Vec2> edge_sum(g.edges.size(), Vec2::Zero());  // Σ of samples of x_j − x_i
    double edge_count = 0.0;

    detail::SyncBus bus(g.adjacency);
    bus.publish_initial(agents);
    std::vector<estimators::MeasurementBatch> batches(static_cast<std::size_t>(n));
    std::vector<const estimators::MeasurementBatch*> batch_ptrs(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i)
      batch_ptrs[static_cast<std::size_t>(i)] = &batches[static_cast<std::size_t>(i)];
    for (std::size_t t = 0; t < steps; ++t) {
      for (auto& batch : batches) {
        batch.relative.clear();
        batch.world_step = static_cast<std::int64_t>(t);
      }
      for (std::size_t k = 0; k < g.edges.size(); ++k) {
        const Edge& e = g.edges[k];
        const auto i = static_cast<std::size_t>(e.i);
        const auto j = static_cast<std::size_t>(e.j);
        const Vec2 s_ij = truth[j] - truth[i] + normal2(rng, c.measurement_std_m);  // 002 eq. (3)
        const Vec2 s_ji = c.shared_measurements
                              ? Vec2(-s_ij)
                              : Vec2(truth[i] - truth[j] + normal2(rng, c.measurement_std_m));
        const Mat2 cov = var * Mat2::Identity();
        batches[i].relative.push_back(estimators::RelativeMeasurement{e.j, s_ij, cov});
        batches[j].relative.push_back(estimators::RelativeMeasurement{e.i, s_ji, cov});
        edge_sum[k] += c.shared_measurements ? s_ij : Vec2(0.5 * (s_ij - s_ji));
      }
      edge_count += 1.0;
      bus.round(agents, static_cast<std::int64_t>(t), batch_ptrs);
      accumulate_error(t + 1);
      // BLUE on the samples 0…t: L̃ x = Σ_edges ±s̄/σ².
      VecX rhs = VecX::Zero(2 * m);
      for (std::size_t k = 0; k < g.edges.size(); ++k) {
        const Vec2 mean = edge_sum[k] / edge_count;
        const int a = g.edges[k].i - 1;
        const int b = g.edges[k].j - 1;
        if (a >= 0) rhs.segment<2>(2 * a) -= mean / var;
        if (b >= 0) rhs.segment<2>(2 * b) += mean / var;
      }
      const VecX blue = llt.solve(rhs);
      for (int i = 1; i < n; ++i) {
        blue_se[t + 1] += (blue.segment<2>(2 * (i - 1)) - truth[static_cast<std::size_t>(i)]).squaredNorm();
      }
      crb[t + 1] += trace_inverse / (samples_per_step * edge_count);
    }
  }
  const double denom = static_cast<double>(c.runs) * m;
  result.rmse.resize(steps + 1);
  result.blue_rmse.resize(steps + 1);
  result.crb_rmse.resize(steps + 1);
  for (std::size_t t = 0; t <= steps; ++t) {
    result.rmse[t] = std::sqrt(se[t] / denom);
    result.blue_rmse[t] = t == 0 ? kNaN : std::sqrt(blue_se[t] / denom);
    result.crb_rmse[t] = t == 0 ? kNaN : std::sqrt(crb[t] / denom);
  }
  return result;
}

StaticDleExperimentResult run_static_dle_experiment(const StaticDleExperimentConfig& c) {
  if (c.num_nodes < 1 || c.steps < 1 || c.runs < 1 || c.target_dim < 1) {
    throw std::invalid_argument("static_dle_experiment: bad sizes");
  }
  std::mt19937_64 rng(c.seed);
  const auto steps = static_cast<std::size_t>(c.steps);
  const Eigen::Index d = c.target_dim;
  std::vector<double> se(steps + 1, 0.0);
  std::vector<double> counted(steps + 1, 0.0);
  std::vector<double> central_se(steps + 1, 0.0);
  std::vector<double> central_crb(steps + 1, 0.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double var = c.observation_std * c.observation_std;
  for (int run = 0; run < c.runs; ++run) {
    Graph g;
    for (int attempt = 0;; ++attempt) {
      if (attempt > 10000) throw std::runtime_error("static_dle_experiment: no connected graph");
      g = make_graph(uniform_points(c.num_nodes, c.side_m, rng), c.radius_m);
      if (detail::connected(g.adjacency)) break;
    }
    VecX y(d);
    for (Eigen::Index k = 0; k < d; ++k) y(k) = c.target_std * normal(rng);
    std::vector<std::unique_ptr<estimators::Estimator>> agents;
    std::vector<const estimators::consensus::Dle*> dle;
    std::vector<MatX> H;
    MatX M_total = MatX::Zero(d, d);
    for (int i = 0; i < c.num_nodes; ++i) {
      MatX Hi(2, d);
      for (Eigen::Index r = 0; r < 2; ++r) {
        for (Eigen::Index k = 0; k < d; ++k) Hi(r, k) = normal(rng);
      }
      H.push_back(Hi);
      M_total += Hi.transpose() * Hi / var;
      estimators::consensus::DleParams params;
      params.target_dim = c.target_dim;
      params.H = Hi;
      estimators::AgentSetup setup;
      setup.id = i;
      setup.initial_guess_m = g.positions[static_cast<std::size_t>(i)];
      auto agent = std::make_unique<estimators::consensus::Dle>(setup, params);
      dle.push_back(agent.get());
      agents.push_back(std::move(agent));
    }
    detail::SyncBus bus(g.adjacency);
    bus.publish_initial(agents);
    std::vector<estimators::MeasurementBatch> batches(static_cast<std::size_t>(c.num_nodes));
    std::vector<const estimators::MeasurementBatch*> batch_ptrs;
    for (std::size_t i = 0; i < batches.size(); ++i) {
      for (const int j : g.adjacency[i]) batches[i].neighbours.push_back(j);
      batch_ptrs.push_back(&batches[i]);
    }
    VecX central_info = VecX::Zero(d);
    const MatX M_inverse = M_total.inverse();
    for (std::size_t t = 1; t <= steps; ++t) {
      for (std::size_t i = 0; i < batches.size(); ++i) {
        const Vec2 noise(c.observation_std * normal(rng), c.observation_std * normal(rng));
        const Vec2 z = H[i] * y + noise;  // 002 eq. (2)
        batches[i].targets = {estimators::TargetObservation{0, z, var * Mat2::Identity(), 0}};
        batches[i].world_step = static_cast<std::int64_t>(t);
        central_info += H[i].transpose() * z / var;
      }
      bus.round(agents, static_cast<std::int64_t>(t), batch_ptrs);
      for (const auto* node : dle) {
        if (!node->has_target_estimate()) continue;
        se[t] += (node->target_estimate() - y).squaredNorm();
        counted[t] += 1.0;
      }
      const double tt = static_cast<double>(t);
      central_se[t] += (M_inverse * central_info / tt - y).squaredNorm();
      central_crb[t] += M_inverse.trace() / tt;
    }
  }
  StaticDleExperimentResult result;
  result.mse.assign(steps + 1, kNaN);
  result.centralized_mse.assign(steps + 1, kNaN);
  result.centralized_crb.assign(steps + 1, kNaN);
  result.fraction_with_estimate.assign(steps + 1, 0.0);
  for (std::size_t t = 1; t <= steps; ++t) {
    if (counted[t] > 0.0) result.mse[t] = se[t] / counted[t];
    result.centralized_mse[t] = central_se[t] / c.runs;
    result.centralized_crb[t] = central_crb[t] / c.runs;
    result.fraction_with_estimate[t] = counted[t] / (static_cast<double>(c.runs) * c.num_nodes);
  }
  return result;
}

}  // namespace swarmloc::sim::experiments
