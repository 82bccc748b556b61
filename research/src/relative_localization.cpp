#include "swarmloc/research/relative_localization.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <stdexcept>

#include "experiment_graphs.hpp"
#include "parallel_runs.hpp"
#include "swarmloc/estimators/consensus/jacobi.hpp"
#include "swarmloc/world/world.hpp"
#include "sync_bus.hpp"

namespace swarmloc::research {
namespace {

using detail::Adjacency;
using detail::Edge;
using detail::Graph;
using detail::make_graph;
using detail::normal2;
using detail::uniform_points;
constexpr double kNoRmse = std::numeric_limits<double>::quiet_NaN();

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

/// BLUE normal matrix L̃ = (Laplacian ⊗ I₂)/σ² without node 0 (Atanasov et al. eq. (8)).
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

/// One step's relative measurements of every edge (Atanasov et al. eq. (3)) into the batches; adds each
/// edge's sample of x_j − x_i to edge_sum.
void measure_edges(const JacobiExperimentConfig& c, const Graph& g, const std::vector<Vec2>& truth,
                   std::mt19937_64& rng, std::vector<estimators::MeasurementBatch>& batches,
                   std::vector<Vec2>& edge_sum) {
  const double var = c.measurement_std_m * c.measurement_std_m;
  for (std::size_t k = 0; k < g.edges.size(); ++k) {
    const Edge& e = g.edges[k];
    const auto i = static_cast<std::size_t>(e.i);
    const auto j = static_cast<std::size_t>(e.j);
    const Vec2 s_ij = truth[j] - truth[i] + normal2(rng, c.measurement_std_m);  // Atanasov et al. eq. (3)
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
    result.blue_rmse[t] = t == 0 ? kNoRmse : std::sqrt(sums.blue_se[t] / denom);
    result.crb_rmse[t] = t == 0 ? kNoRmse : std::sqrt(sums.crb[t] / denom);
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

/// Sensors placed as c.placement says, with exactly c.num_edges edges, redrawn until connected.
Graph draw_field_graph(const JointFieldExperimentConfig& c, std::mt19937_64& rng, int& rejected) {
  for (int attempt = 0;; ++attempt) {
    if (attempt >= c.max_graph_attempts)
      throw std::runtime_error("joint_field_experiment: no connected graph in max_graph_attempts draws");
    const auto points = c.placement == SensorPlacement::kCellBoundaries
                            ? cell_boundary_points(c.num_nodes, c.side_m, c.cells_per_side, rng)
                            : uniform_points(c.num_nodes, c.side_m, rng);
    Graph g = graph_with_edges(points, c.num_edges);
    if (detail::connected(g.adjacency)) return g;
    ++rejected;
  }
}

/// The field experiment's sensors: each runs the joint estimator and, as a baseline, the field estimator
/// that knows its position.
struct JointFieldNodes {
  std::vector<std::unique_ptr<estimators::Estimator>> joint_agents;
  std::vector<std::unique_ptr<estimators::Estimator>> known_agents;
  std::vector<const estimators::consensus::JointLocalizationField*> joint;
  std::vector<const estimators::consensus::JointLocalizationField*> known;
  std::vector<Vec2> truth;  ///< in node 0's frame
  MatX M;                   ///< Σ_i h_i h_iᵀ / V (true positions)
  std::vector<VecX> h_true;
};

JointFieldNodes make_field_nodes(const JointFieldExperimentConfig& c,
                                 const estimators::consensus::FieldSensor& sensor, const Graph& g,
                                 std::mt19937_64& rng) {
  namespace consensus = estimators::consensus;
  const int d = sensor.grid.cells();
  const double reading_var = c.observation_std * c.observation_std;
  consensus::JointFieldParams params;
  params.sensor = sensor;
  params.reference_position_m = g.positions[0];
  params.delta = c.delta;
  JointFieldNodes nodes;
  nodes.truth.resize(g.positions.size());
  nodes.M = MatX::Zero(d, d);
  for (int i = 0; i < c.num_nodes; ++i) {
    const auto u = static_cast<std::size_t>(i);
    nodes.truth[u] = g.positions[u] - g.positions[0];  // node 0's frame
    nodes.h_true.push_back(consensus::field_observation_row(sensor, g.positions[u]));
    nodes.M += nodes.h_true.back() * nodes.h_true.back().transpose() / reading_var;
    estimators::AgentSetup setup;
    setup.id = i;
    setup.anchor = i == 0;
    setup.initial_guess_m = i == 0 ? Vec2::Zero() : Vec2(nodes.truth[u] + normal2(rng, c.prior_std_m));
    params.localize = true;
    auto agent = std::make_unique<consensus::JointLocalizationField>(setup, params);
    nodes.joint.push_back(agent.get());
    nodes.joint_agents.push_back(std::move(agent));
    setup.initial_guess_m = nodes.truth[u];
    params.localize = false;
    auto baseline = std::make_unique<consensus::JointLocalizationField>(setup, params);
    nodes.known.push_back(baseline.get());
    nodes.known_agents.push_back(std::move(baseline));
  }
  return nodes;
}

/// Step t's field readings (Atanasov et al. eq. (2), at the true positions; their information sum into
/// central_info) and relative measurements (eq. (3), shared [C-7]) into the batches.
void measure_field_step(const JointFieldExperimentConfig& c, const Graph& g, const JointFieldNodes& nodes,
                        const VecX& y, std::size_t t, std::normal_distribution<double>& reading_noise,
                        std::mt19937_64& rng, std::vector<estimators::MeasurementBatch>& batches,
                        VecX& central_info) {
  const double var = c.measurement_std_m * c.measurement_std_m;
  const double reading_var = c.observation_std * c.observation_std;
  for (std::size_t i = 0; i < batches.size(); ++i) {
    auto& batch = batches[i];
    batch.relative.clear();
    batch.world_step = static_cast<std::int64_t>(t);
    const double z = nodes.h_true[i].dot(y) + reading_noise(rng);
    Mat2 reading_cov = Mat2::Identity();
    reading_cov(0, 0) = reading_var;
    batch.targets = {
        estimators::TargetObservation{0, Vec2(z, 0.0), reading_cov, estimators::consensus::kFieldReading}};
    central_info += nodes.h_true[i] * (z / reading_var);
  }
  for (const Edge& e : g.edges) {
    const auto i = static_cast<std::size_t>(e.i);
    const auto j = static_cast<std::size_t>(e.j);
    const Vec2 s_ij = nodes.truth[j] - nodes.truth[i] + normal2(rng, c.measurement_std_m);
    batches[i].relative.push_back(estimators::RelativeMeasurement{e.j, s_ij, var * Mat2::Identity()});
    batches[j].relative.push_back(estimators::RelativeMeasurement{e.i, -s_ij, var * Mat2::Identity()});
  }
}

JointFieldRunSums run_joint_field_once(const JointFieldExperimentConfig& c,
                                       const estimators::consensus::FieldSensor& sensor, int run) {
  std::seed_seq seeds{c.seed, static_cast<std::uint64_t>(run)};  // runs are independent of thread count
  std::mt19937_64 rng(seeds);
  const auto steps = static_cast<std::size_t>(c.steps);
  const int n = c.num_nodes;
  const int d = sensor.grid.cells();
  JointFieldRunSums sums;
  std::vector<double>& location_se = sums.location_se;
  std::vector<double>& field_se = sums.field_se;
  std::vector<double>& known_se = sums.known_se;
  std::vector<double>& central_se = sums.central_se;
  for (auto* v : {&location_se, &field_se, &known_se, &central_se}) v->assign(steps + 1, 0.0);
  const Graph g = draw_field_graph(c, rng, sums.graphs_rejected);
  sums.radius_m = g.radius_m;
  const VecX y = world::draw_gaussian_field(sensor.grid, c.field_std, c.field_correlation_m, rng);
  JointFieldNodes nodes = make_field_nodes(c, sensor, g, rng);
  const auto& joint = nodes.joint;
  const auto& known = nodes.known;
  const auto& truth = nodes.truth;
  MatX M_regularized = nodes.M;
  M_regularized.diagonal().array() += c.delta;
  const Eigen::LLT<MatX> central_llt(M_regularized);
  VecX central_info = VecX::Zero(d);
  for (int i = 1; i < n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    location_se[0] += (joint[u]->estimate().mean_m - truth[u]).squaredNorm();
  }
  detail::SyncBus joint_bus(g.adjacency);
  detail::SyncBus known_bus(g.adjacency);
  joint_bus.publish_initial(nodes.joint_agents);
  known_bus.publish_initial(nodes.known_agents);
  std::vector<estimators::MeasurementBatch> batches(static_cast<std::size_t>(n));
  std::vector<const estimators::MeasurementBatch*> batch_ptrs;
  for (std::size_t i = 0; i < batches.size(); ++i) {
    for (const int j : g.adjacency[i]) batches[i].neighbours.push_back(j);
    batch_ptrs.push_back(&batches[i]);
  }
  std::normal_distribution<double> reading_noise(0.0, c.observation_std);
  for (std::size_t t = 0; t < steps; ++t) {
    measure_field_step(c, g, nodes, y, t, reading_noise, rng, batches, central_info);
    joint_bus.round(nodes.joint_agents, static_cast<std::int64_t>(t), batch_ptrs);
    known_bus.round(nodes.known_agents, static_cast<std::int64_t>(t), batch_ptrs);
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
  result.field_rmse.assign(steps + 1, kNoRmse);
  result.known_position_field_rmse.assign(steps + 1, kNoRmse);
  result.centralized_field_rmse.assign(steps + 1, kNoRmse);
  for (std::size_t t = 0; t <= steps; ++t) {
    result.location_rmse[t] = std::sqrt(location_se[t] / location_denom);
    if (t == 0) continue;
    result.field_rmse[t] = std::sqrt(field_se[t] / field_denom);
    result.known_position_field_rmse[t] = std::sqrt(known_se[t] / field_denom);
    result.centralized_field_rmse[t] = std::sqrt(central_se[t] / (static_cast<double>(c.runs) * d));
  }
  return result;
}

}  // namespace swarmloc::research
