#include "swarmloc/research/relative_localization.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <random>
#include <stdexcept>

#include "parallel_runs.hpp"
#include "swarmloc/estimators/consensus/dle.hpp"
#include "swarmloc/estimators/consensus/jacobi.hpp"
#include "swarmloc/models/measurement_models.hpp"
#include "swarmloc/world/world.hpp"
#include "sync_bus.hpp"

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

/// The graph on `points` whose radius is the num_edges-th smallest pairwise distance (exactly num_edges
/// edges, [C-5]).
Graph graph_with_edges(const std::vector<Vec2>& points, int num_edges) {
  std::vector<double> distances;
  for (std::size_t i = 0; i < points.size(); ++i) {
    for (std::size_t j = i + 1; j < points.size(); ++j) distances.push_back((points[i] - points[j]).norm());
  }
  if (num_edges < 1 || static_cast<std::size_t>(num_edges) > distances.size())
    throw std::invalid_argument("num_edges: must be in 1 .. n(n-1)/2");
  const auto k = static_cast<std::size_t>(num_edges - 1);
  std::nth_element(distances.begin(), distances.begin() + static_cast<std::ptrdiff_t>(k), distances.end());
  return make_graph(points, distances[k]);
}

/// Uniform points with exactly num_edges edges, redrawn until connected.
Graph draw_graph_with_edges(const JacobiExperimentConfig& c, std::mt19937_64& rng, int& rejected) {
  for (int attempt = 0; attempt < c.max_graph_attempts; ++attempt) {
    Graph g = graph_with_edges(uniform_points(c.num_nodes, c.side_m, rng), c.num_edges);
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

/// Sensor i sits on the left or the bottom edge of cell i mod cells² (uniform along the edge), the edge that
/// the floor convention assigns to that cell: every cell is read by its own sensors (so the field is
/// observable with true positions), and every sensor sits on a cell boundary.
std::vector<Vec2> cell_boundary_points(int n, double side_m, int cells, std::mt19937_64& rng) {
  const double cell_m = side_m / cells;
  std::uniform_real_distribution<double> along(0.0, cell_m);
  std::bernoulli_distribution left_edge(0.5);
  std::vector<Vec2> points(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const int cell = i % (cells * cells);
    const Vec2 corner = cell_m * Vec2(cell % cells, cell / cells);
    const double offset = along(rng);
    points[static_cast<std::size_t>(i)] = corner + (left_edge(rng) ? Vec2(0.0, offset) : Vec2(offset, 0.0));
  }
  return points;
}

/// Per-step sums over the runs of the Jacobi experiment.
struct JacobiSums {
  std::vector<double> se, blue_se, crb;
};

/// BLUE normal matrix L̃ = (Laplacian ⊗ I₂)/σ² without node 0 (002 eq. (8)).
MatX blue_normal_matrix(const Graph& g, int m, double var) {
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
  return L;
}

/// One step's relative measurements of every edge (002 eq. (3)) into the batches; adds each edge's sample
/// of x_j − x_i to edge_sum.
void measure_edges(const JacobiExperimentConfig& c, const Graph& g, const std::vector<Vec2>& truth,
                   std::mt19937_64& rng, std::vector<estimators::MeasurementBatch>& batches,
                   std::vector<Vec2>& edge_sum) {
  const double var = c.measurement_std_m * c.measurement_std_m;
  for (std::size_t k = 0; k < g.edges.size(); ++k) {
    const Edge& e = g.edges[k];
    const auto i = static_cast<std::size_t>(e.i);
    const auto j = static_cast<std::size_t>(e.j);
    const Vec2 s_ij = truth[j] - truth[i] + normal2(rng, c.measurement_std_m);  // 002 eq. (3)
    const Vec2 s_ji =
        c.shared_measurements ? Vec2(-s_ij) : Vec2(truth[i] - truth[j] + normal2(rng, c.measurement_std_m));
    const Mat2 cov = var * Mat2::Identity();
    batches[i].relative.push_back(estimators::RelativeMeasurement{e.j, s_ij, cov});
    batches[j].relative.push_back(estimators::RelativeMeasurement{e.i, s_ji, cov});
    edge_sum[k] += c.shared_measurements ? s_ij : Vec2(0.5 * (s_ij - s_ji));
  }
}

/// Adds to `se` the squared error of each of nodes 1…n−1 under the BLUE on the samples so far:
/// L̃ x = Σ_edges ±s̄/σ².
void add_blue_squared_error(const Graph& g, const Eigen::LLT<MatX>& llt, const std::vector<Vec2>& edge_sum,
                            double edge_count, double var, const std::vector<Vec2>& truth, double& se) {
  const auto m = static_cast<int>(truth.size()) - 1;
  VecX rhs = VecX::Zero(2 * m);
  for (std::size_t k = 0; k < g.edges.size(); ++k) {
    const Vec2 mean = edge_sum[k] / edge_count;
    const int a = g.edges[k].i - 1;
    const int b = g.edges[k].j - 1;
    if (a >= 0) rhs.segment<2>(2 * a) -= mean / var;
    if (b >= 0) rhs.segment<2>(2 * b) += mean / var;
  }
  const VecX blue = llt.solve(rhs);
  for (int i = 1; i <= m; ++i) {
    se += (blue.segment<2>(2 * (i - 1)) - truth[static_cast<std::size_t>(i)]).squaredNorm();
  }
}

/// One run: a graph, priors, and c.steps steps of Jacobi against the BLUE and the CRB.
void run_jacobi_once(const JacobiExperimentConfig& c, std::mt19937_64& rng, JacobiExperimentResult& result,
                     JacobiSums& sums) {
  const int n = c.num_nodes;
  const int m = n - 1;  // unknowns: nodes 1…n−1
  const double var = c.measurement_std_m * c.measurement_std_m;
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
      sums.se[t] +=
          (jacobi[static_cast<std::size_t>(i)]->mean() - truth[static_cast<std::size_t>(i)]).squaredNorm();
    }
  };
  accumulate_error(0);
  // One factorization of the BLUE normal matrix per run.
  const Eigen::LLT<MatX> llt(blue_normal_matrix(g, m, var));
  const double trace_inverse = llt.solve(MatX::Identity(2 * m, 2 * m)).trace();
  const double samples_per_step = c.shared_measurements ? 1.0 : 2.0;
  std::vector<Vec2> edge_sum(g.edges.size(), Vec2::Zero());  // Σ of samples of x_j − x_i
  double edge_count = 0.0;

  detail::SyncBus bus(g.adjacency);
  bus.publish_initial(agents);
  std::vector<estimators::MeasurementBatch> batches(static_cast<std::size_t>(n));
  std::vector<const estimators::MeasurementBatch*> batch_ptrs(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) batch_ptrs[static_cast<std::size_t>(i)] = &batches[static_cast<std::size_t>(i)];
  for (std::size_t t = 0; t < static_cast<std::size_t>(c.steps); ++t) {
    for (auto& batch : batches) {
      batch.relative.clear();
      batch.world_step = static_cast<std::int64_t>(t);
    }
    measure_edges(c, g, truth, rng, batches, edge_sum);
    edge_count += 1.0;
    bus.round(agents, static_cast<std::int64_t>(t), batch_ptrs);
    // Further exchanges before the next measurement: each sweeps eq. (9) again on the same means.
    for (int sweep = 1; sweep < c.sweeps_per_step; ++sweep)
      bus.round(agents, static_cast<std::int64_t>(t), {});
    accumulate_error(t + 1);
    add_blue_squared_error(g, llt, edge_sum, edge_count, var, truth, sums.blue_se[t + 1]);
    sums.crb[t + 1] += trace_inverse / (samples_per_step * edge_count);
  }
}

}  // namespace

JacobiExperimentResult run_jacobi_experiment(const JacobiExperimentConfig& c) {
  if (c.num_nodes < 2 || c.steps < 1 || c.runs < 1 || c.sweeps_per_step < 1)
    throw std::invalid_argument("jacobi_experiment: bad sizes");
  std::mt19937_64 rng(c.seed);
  const auto steps = static_cast<std::size_t>(c.steps);
  JacobiSums sums{std::vector<double>(steps + 1, 0.0), std::vector<double>(steps + 1, 0.0),
                  std::vector<double>(steps + 1, 0.0)};
  JacobiExperimentResult result;
  for (int run = 0; run < c.runs; ++run) run_jacobi_once(c, rng, result, sums);
  const double denom = static_cast<double>(c.runs) * (c.num_nodes - 1);
  result.rmse.resize(steps + 1);
  result.blue_rmse.resize(steps + 1);
  result.crb_rmse.resize(steps + 1);
  for (std::size_t t = 0; t <= steps; ++t) {
    result.rmse[t] = std::sqrt(sums.se[t] / denom);
    result.blue_rmse[t] = t == 0 ? kNaN : std::sqrt(sums.blue_se[t] / denom);
    result.crb_rmse[t] = t == 0 ? kNaN : std::sqrt(sums.crb[t] / denom);
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

namespace {

/// Squared errors of one run of the field experiment, summed over sensors (and cells), per step.
struct JointFieldRunSums {
  std::vector<double> location_se, field_se, known_se, central_se;
  double radius_m = 0.0;
  int graphs_rejected = 0;
};

JointFieldRunSums run_joint_field_once(const JointFieldExperimentConfig& c,
                                       const estimators::consensus::FieldSensor& sensor, int run) {
  namespace consensus = estimators::consensus;
  std::seed_seq seeds{c.seed, static_cast<std::uint64_t>(run)};  // runs are independent of thread count
  std::mt19937_64 rng(seeds);
  const auto steps = static_cast<std::size_t>(c.steps);
  const int n = c.num_nodes;
  const int d = sensor.grid.cells();
  const double var = c.measurement_std_m * c.measurement_std_m;
  const double reading_var = c.observation_std * c.observation_std;
  JointFieldRunSums sums;
  std::vector<double>& location_se = sums.location_se;
  std::vector<double>& field_se = sums.field_se;
  std::vector<double>& known_se = sums.known_se;
  std::vector<double>& central_se = sums.central_se;
  for (auto* v : {&location_se, &field_se, &known_se, &central_se}) v->assign(steps + 1, 0.0);
  Graph g;
  for (int attempt = 0;; ++attempt) {
    if (attempt >= c.max_graph_attempts)
      throw std::runtime_error("joint_field_experiment: no connected graph in max_graph_attempts draws");
    const auto points = c.placement == SensorPlacement::kCellBoundaries
                            ? cell_boundary_points(n, c.side_m, c.cells_per_side, rng)
                            : uniform_points(n, c.side_m, rng);
    g = graph_with_edges(points, c.num_edges);
    if (detail::connected(g.adjacency)) break;
    ++sums.graphs_rejected;
  }
  sums.radius_m = g.radius_m;
  const VecX y = draw_gaussian_field(sensor.grid, c.field_std, c.field_correlation_m, rng);
  consensus::JointFieldParams params;
  params.sensor = sensor;
  params.reference_position_m = g.positions[0];
  params.delta = c.delta;
  std::vector<std::unique_ptr<estimators::Estimator>> joint_agents;
  std::vector<std::unique_ptr<estimators::Estimator>> known_agents;
  std::vector<const consensus::JointLocalizationField*> joint;
  std::vector<const consensus::JointLocalizationField*> known;
  std::vector<Vec2> truth(g.positions.size());
  MatX M = MatX::Zero(d, d);  // Σ_i h_i h_iᵀ / V (true positions)
  std::vector<VecX> h_true;
  for (int i = 0; i < n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    truth[u] = g.positions[u] - g.positions[0];  // node 0's frame
    h_true.push_back(consensus::field_observation_row(sensor, g.positions[u]));
    M += h_true.back() * h_true.back().transpose() / reading_var;
    estimators::AgentSetup setup;
    setup.id = i;
    setup.anchor = i == 0;
    setup.initial_guess_m = i == 0 ? Vec2::Zero() : Vec2(truth[u] + normal2(rng, c.prior_std_m));
    params.localize = true;
    auto agent = std::make_unique<consensus::JointLocalizationField>(setup, params);
    joint.push_back(agent.get());
    joint_agents.push_back(std::move(agent));
    setup.initial_guess_m = truth[u];
    params.localize = false;
    auto baseline = std::make_unique<consensus::JointLocalizationField>(setup, params);
    known.push_back(baseline.get());
    known_agents.push_back(std::move(baseline));
  }
  MatX M_regularized = M;
  M_regularized.diagonal().array() += c.delta;
  const Eigen::LLT<MatX> central_llt(M_regularized);
  VecX central_info = VecX::Zero(d);
  for (int i = 1; i < n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    location_se[0] += (joint[u]->estimate().mean_m - truth[u]).squaredNorm();
  }
  detail::SyncBus joint_bus(g.adjacency);
  detail::SyncBus known_bus(g.adjacency);
  joint_bus.publish_initial(joint_agents);
  known_bus.publish_initial(known_agents);
  std::vector<estimators::MeasurementBatch> batches(static_cast<std::size_t>(n));
  std::vector<const estimators::MeasurementBatch*> batch_ptrs;
  for (std::size_t i = 0; i < batches.size(); ++i) {
    for (const int j : g.adjacency[i]) batches[i].neighbours.push_back(j);
    batch_ptrs.push_back(&batches[i]);
  }
  std::normal_distribution<double> reading_noise(0.0, c.observation_std);
  for (std::size_t t = 0; t < steps; ++t) {
    for (std::size_t i = 0; i < batches.size(); ++i) {
      auto& batch = batches[i];
      batch.relative.clear();
      batch.world_step = static_cast<std::int64_t>(t);
      const double z = h_true[i].dot(y) + reading_noise(rng);  // 002 eq. (2), true position
      Mat2 reading_cov = Mat2::Identity();
      reading_cov(0, 0) = reading_var;
      batch.targets = {estimators::TargetObservation{0, Vec2(z, 0.0), reading_cov, consensus::kFieldReading}};
      central_info += h_true[i] * (z / reading_var);
    }
    for (const Edge& e : g.edges) {
      const auto i = static_cast<std::size_t>(e.i);
      const auto j = static_cast<std::size_t>(e.j);
      const Vec2 s_ij = truth[j] - truth[i] + normal2(rng, c.measurement_std_m);  // eq. (3), shared [C-7]
      batches[i].relative.push_back(estimators::RelativeMeasurement{e.j, s_ij, var * Mat2::Identity()});
      batches[j].relative.push_back(estimators::RelativeMeasurement{e.i, -s_ij, var * Mat2::Identity()});
    }
    joint_bus.round(joint_agents, static_cast<std::int64_t>(t), batch_ptrs);
    known_bus.round(known_agents, static_cast<std::int64_t>(t), batch_ptrs);
    for (int i = 0; i < n; ++i) {
      const auto u = static_cast<std::size_t>(i);
      if (i > 0) location_se[t + 1] += (joint[u]->estimate().mean_m - truth[u]).squaredNorm();
      field_se[t + 1] += (joint[u]->field_estimate() - y).squaredNorm();
      known_se[t + 1] += (known[u]->field_estimate() - y).squaredNorm();
    }
    // (t+1)(M + δI) ŷ = Σ_τ Σ_i h_i z_i(τ)/V
    central_se[t + 1] += (central_llt.solve(central_info / static_cast<double>(t + 1)) - y).squaredNorm();
  }
  return sums;
}

}  // namespace

JointFieldExperimentResult run_joint_field_experiment(const JointFieldExperimentConfig& c) {
  namespace consensus = estimators::consensus;
  if (c.num_nodes < 2 || c.steps < 1 || c.runs < 1 || c.cells_per_side < 2 || c.threads < 1)
    throw std::invalid_argument("joint_field_experiment: bad sizes");
  consensus::FieldSensor sensor;
  sensor.grid.cell_m = c.side_m / c.cells_per_side;
  sensor.grid.columns = c.cells_per_side;
  sensor.grid.rows = c.cells_per_side;
  sensor.sensing = c.sensing;
  sensor.radius_m = c.sensing_radius_m;
  consensus::validate(sensor);
  std::vector<JointFieldRunSums> runs(static_cast<std::size_t>(c.runs));
  detail::parallel_runs(c.runs, c.threads, [&](int run) {
    runs[static_cast<std::size_t>(run)] = run_joint_field_once(c, sensor, run);
  });
  const auto steps = static_cast<std::size_t>(c.steps);
  const int n = c.num_nodes;
  const int d = sensor.grid.cells();
  std::vector<double> location_se(steps + 1, 0.0);
  std::vector<double> field_se(steps + 1, 0.0);
  std::vector<double> known_se(steps + 1, 0.0);
  std::vector<double> central_se(steps + 1, 0.0);
  JointFieldExperimentResult result;
  for (const JointFieldRunSums& run : runs) {  // in run order: bit-identical for any thread count
    for (std::size_t t = 0; t <= steps; ++t) {
      location_se[t] += run.location_se[t];
      field_se[t] += run.field_se[t];
      known_se[t] += run.known_se[t];
      central_se[t] += run.central_se[t];
    }
    result.mean_radius_m += run.radius_m / c.runs;
    result.graphs_rejected += run.graphs_rejected;
  }
  const double location_denom = static_cast<double>(c.runs) * (n - 1);
  const double field_denom = static_cast<double>(c.runs) * n * d;
  result.location_rmse.resize(steps + 1);
  result.field_rmse.assign(steps + 1, kNaN);
  result.known_position_field_rmse.assign(steps + 1, kNaN);
  result.centralized_field_rmse.assign(steps + 1, kNaN);
  for (std::size_t t = 0; t <= steps; ++t) {
    result.location_rmse[t] = std::sqrt(location_se[t] / location_denom);
    if (t == 0) continue;
    result.field_rmse[t] = std::sqrt(field_se[t] / field_denom);
    result.known_position_field_rmse[t] = std::sqrt(known_se[t] / field_denom);
    result.centralized_field_rmse[t] = std::sqrt(central_se[t] / (static_cast<double>(c.runs) * d));
  }
  return result;
}

TrackingExperimentResult run_tracking_experiment(const TrackingExperimentConfig& c) {
  if (c.num_sensors < 2 || c.num_targets < 1 || c.steps < 1 || c.runs < 1)
    throw std::invalid_argument("tracking_experiment: bad sizes");
  std::mt19937_64 rng(c.seed);
  const auto steps = static_cast<std::size_t>(c.steps);
  const double tau = c.dt_s;
  MatX F = MatX::Identity(4, 4);
  F.block<2, 2>(0, 2) = tau * Mat2::Identity();
  MatX W(4, 4);
  W << tau * tau * tau / 3 * Mat2::Identity(), tau * tau / 2 * Mat2::Identity(),
      tau * tau / 2 * Mat2::Identity(), tau * Mat2::Identity();
  W *= c.q;
  const Eigen::LLT<MatX> W_root(W);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> heading(0.0, 0.5 * std::numbers::pi);
  std::vector<double> node0_pos(steps + 1, 0.0), others_pos(steps + 1, 0.0), central_pos(steps + 1, 0.0);
  std::vector<double> node0_vel(steps + 1, 0.0), others_vel(steps + 1, 0.0), central_vel(steps + 1, 0.0);
  const auto n = static_cast<std::size_t>(c.num_sensors);
  for (int run = 0; run < c.runs; ++run) {
    Graph g;
    for (int attempt = 0;; ++attempt) {
      if (attempt > 10000) throw std::runtime_error("tracking_experiment: no connected graph");
      auto points = uniform_points(c.num_sensors, c.side_m, rng);
      points[0] = Vec2::Zero();  // node 1 of the paper at the origin
      g = make_graph(points, c.radius_m);
      if (detail::connected(g.adjacency)) break;
    }
    for (int k = 0; k < c.num_targets; ++k) {
      VecX y(4);
      const double angle = heading(rng);
      y << c.start_std_m * normal(rng), c.start_std_m * normal(rng), c.speed_mps * std::cos(angle),
          c.speed_mps * std::sin(angle);
      estimators::consensus::DleParams params;
      params.target = k;
      params.target_dim = 4;
      params.F = F;
      params.W = W;
      params.initial_information = c.initial_information;
      std::vector<std::unique_ptr<estimators::Estimator>> agents;
      std::vector<const estimators::consensus::Dle*> dle;
      for (std::size_t i = 0; i < n; ++i) {
        estimators::AgentSetup setup;
        setup.id = static_cast<int>(i);
        setup.initial_guess_m = g.positions[i];
        auto agent = std::make_unique<estimators::consensus::Dle>(setup, params);
        dle.push_back(agent.get());
        agents.push_back(std::move(agent));
      }
      detail::SyncBus bus(g.adjacency);
      bus.publish_initial(agents);
      std::vector<estimators::MeasurementBatch> batches(n);
      std::vector<const estimators::MeasurementBatch*> batch_ptrs;
      for (std::size_t i = 0; i < n; ++i) {
        for (const int j : g.adjacency[i]) batches[i].neighbours.push_back(j);
        batch_ptrs.push_back(&batches[i]);
      }
      // Centralized EKF in information form on every sensor's reading (§4.6 baseline).
      VecX central_mean = VecX::Zero(4);
      MatX central_info = c.initial_information * MatX::Identity(4, 4);
      for (std::size_t t = 1; t <= steps; ++t) {
        if (t > 1) {  // y(t) = F y(t−1) + η (002 eq. (1)); the first step observes the initial state
          VecX eta(4);
          for (int r = 0; r < 4; ++r) eta(r) = normal(rng);
          y = F * y + W_root.matrixL() * eta;
        }
        MatX info_sum = MatX::Zero(4, 4);
        VecX score = VecX::Zero(4);
        for (std::size_t i = 0; i < n; ++i) {
          const Vec2 d = y.head<2>() - g.positions[i];
          const double distance = d.norm();
          const double range_std = c.range_std_m + c.range_std_per_m * distance;
          const double bearing_std = c.bearing_std_rad + c.bearing_std_per_m * distance;
          const Vec2 z(distance + range_std * normal(rng),
                       models::wrap_angle(std::atan2(d.y(), d.x()) + bearing_std * normal(rng)));
          const Mat2 V = Vec2(range_std * range_std, bearing_std * bearing_std).asDiagonal();
          batches[i].targets = {estimators::TargetObservation{k, z, V, 1}};
          batches[i].world_step = static_cast<std::int64_t>(t);
          const auto r = models::range(g.positions[i], Vec2(central_mean.head<2>()));
          const auto b = models::bearing(g.positions[i], Vec2(central_mean.head<2>()));
          if (!r || !b) continue;
          MatX H = MatX::Zero(2, 4);
          H.block<1, 2>(0, 0) = r->d_xj;
          H.block<1, 2>(1, 0) = b->d_xj;
          const Vec2 residual(z(0) - r->value, models::bearing_residual(z(1), b->value));
          const MatX Vinv_H = V.inverse() * H;
          info_sum += H.transpose() * Vinv_H;
          score += Vinv_H.transpose() * residual;
        }
        bus.round(agents, static_cast<std::int64_t>(t), batch_ptrs);
        central_info += info_sum;
        central_mean += central_info.ldlt().solve(score);
        const auto tracked = [&](const VecX& estimate, std::vector<double>& pos, std::vector<double>& vel,
                                 double weight) {
          pos[t] += weight * (estimate.head<2>() - y.head<2>()).squaredNorm();
          vel[t] += weight * (estimate.tail<2>() - y.tail<2>()).squaredNorm();
        };
        tracked(dle[0]->target_estimate(), node0_pos, node0_vel, 1.0);
        for (std::size_t i = 1; i < n; ++i)  // others: the mean over sensors 2…n of the squared error
          tracked(dle[i]->target_estimate(), others_pos, others_vel, 1.0 / static_cast<double>(n - 1));
        tracked(central_mean, central_pos, central_vel, 1.0);
        // Centralized prediction: P = F Λ⁻¹ Fᵀ + W.
        const MatX P = F * central_info.ldlt().solve(MatX::Identity(4, 4)) * F.transpose() + W;
        central_info = P.ldlt().solve(MatX::Identity(4, 4));
        central_mean = F * central_mean;
      }
    }
  }
  const double denom = static_cast<double>(c.runs) * c.num_targets;
  TrackingExperimentResult result;
  auto finish = [&](const std::vector<double>& sums, std::vector<double>& out) {
    out.assign(steps + 1, kNaN);
    for (std::size_t t = 1; t <= steps; ++t) out[t] = std::sqrt(sums[t] / denom);
  };
  finish(node0_pos, result.node0_position_rmse);
  finish(others_pos, result.others_position_rmse);
  finish(central_pos, result.centralized_position_rmse);
  finish(node0_vel, result.node0_velocity_rmse);
  finish(others_vel, result.others_velocity_rmse);
  finish(central_vel, result.centralized_velocity_rmse);
  return result;
}

}  // namespace swarmloc::sim::experiments
