#include "swarmloc/research/sdp_refinement.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "parallel_runs.hpp"
#include "sync_bus.hpp"

namespace swarmloc::research {

namespace gradient = estimators::gradient;
using detail::parallel_runs;

namespace {

double median(std::vector<double> values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  const std::size_t mid = values.size() / 2;
  return values.size() % 2 == 1 ? values[mid] : 0.5 * (values[mid - 1] + values[mid]);
}

}  // namespace

void validate(const GeometricGraphConfig& c) {
  auto fail = [](const std::string& what) { throw std::invalid_argument("geometric_graph." + what); };
  if (c.nodes < 2) fail("nodes: must be >= 2");
  if (!(c.radius > 0.0)) fail("radius: must be > 0");
  if (c.anchors < 0 || c.anchors > c.nodes) fail("anchors: must be in [0, nodes]");
  if (!(c.noise_factor >= 0.0)) fail("noise_factor: must be >= 0");
  if (c.min_unknown_degree < 0) fail("min_unknown_degree: must be >= 0");
  if (c.max_attempts < 1) fail("max_attempts: must be >= 1");
}

LatticeProblem make_geometric_graph_problem(const GeometricGraphConfig& c, std::mt19937_64& rng) {
  validate(c);
  const auto n = static_cast<std::size_t>(c.nodes);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int attempt = 0; attempt < c.max_attempts; ++attempt) {
    LatticeProblem world;
    world.truth.resize(n);
    for (auto& p : world.truth) {
      const double x = uniform(rng);
      p = Vec2(x, uniform(rng));
    }
    std::vector<int> order(n);
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), rng);
    world.problem.anchor.assign(n, false);
    for (int k = 0; k < c.anchors; ++k)
      world.problem.anchor[static_cast<std::size_t>(order[static_cast<std::size_t>(k)])] = true;
    detail::Adjacency adjacency(n);
    for (std::size_t i = 0; i < n; ++i) {
      for (std::size_t j = i + 1; j < n; ++j) {
        const double d = (world.truth[i] - world.truth[j]).norm();
        if (!(d < c.radius)) continue;
        const double noisy = std::abs(d + c.noise_factor * d * normal(rng));  // Calafiore et al. eq. (16)
        world.problem.edges.push_back(gradient::RangeEdge{static_cast<int>(i), static_cast<int>(j), noisy});
        adjacency[i].push_back(static_cast<int>(j));
        adjacency[j].push_back(static_cast<int>(i));
      }
    }
    bool enough = detail::connected(adjacency);
    for (std::size_t i = 0; enough && i < n; ++i) {
      if (!world.problem.anchor[i] && static_cast<int>(adjacency[i].size()) < c.min_unknown_degree)
        enough = false;
    }
    if (!enough) continue;
    world.problem.initial.assign(n, Vec2::Zero());
    for (std::size_t i = 0; i < n; ++i) {
      if (world.problem.anchor[i]) world.problem.initial[i] = world.truth[i];
    }
    return world;
  }
  throw std::runtime_error(
      "geometric_graph: no connected graph with the required degrees in max_attempts draws");
}

double mean_position_error(const std::vector<Vec2>& truth, const std::vector<Vec2>& estimate) {
  if (truth.size() != estimate.size() || truth.empty())
    throw std::invalid_argument("mean_position_error: sizes differ or are empty");
  double sum = 0.0;
  for (std::size_t i = 0; i < truth.size(); ++i) sum += (truth[i] - estimate[i]).norm();
  return sum / static_cast<double>(truth.size());
}

std::vector<std::int64_t> draw_start_ticks(std::size_t nodes, std::int64_t max_skew, std::mt19937_64& rng) {
  if (max_skew < 0) throw std::invalid_argument("draw_start_ticks: max_skew must be >= 0");
  std::uniform_int_distribution<std::int64_t> tick(0, max_skew);
  std::vector<std::int64_t> ticks(nodes);
  for (auto& t : ticks) t = tick(rng);
  return ticks;
}

std::uint64_t run_seed(std::uint64_t seed, int run) {
  // splitmix64 of (seed, run): independent streams per run.
  std::uint64_t z = seed * std::uint64_t{0x9E3779B97F4A7C15} + static_cast<std::uint64_t>(run) +
                    std::uint64_t{0x632BE59BD9B4E5};
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

SdpInstance make_sdp_instance(const GeometricGraphConfig& config, std::mt19937_64& rng,
                              const SdpRelaxationParams& sdp_params) {
  SdpInstance instance;
  instance.world = make_geometric_graph_problem(config, rng);
  instance.sdp = solve_sdp_relaxation(instance.world.problem, sdp_params);
  if (instance.sdp.usable()) {
    instance.world.problem.initial = instance.sdp.positions;
    instance.sdp_error = mean_position_error(instance.world.truth, instance.sdp.positions);
  } else {
    instance.sdp_error = std::numeric_limits<double>::quiet_NaN();
  }
  return instance;
}

gradient::DgBbParams example3_dgbb_params() {
  gradient::DgBbParams params;
  params.rule = gradient::StepRule::kConsensusBb;
  params.consensus_rounds = 20;
  params.abs_tol = 1e-15;
  params.max_updates = 100000;
  return params;
}

std::vector<TableTwoCell> run_table_two(const TableTwoConfig& config, const gradient::DgBbParams& params) {
  if (config.runs < 1) throw std::invalid_argument("table_two.runs: must be >= 1");
  struct Outcome {
    bool usable = false;
    bool inaccurate = false;
    double sdp = 0.0;
    double refined = 0.0;
    std::int64_t tau_end = 0;
  };
  const std::size_t cells = config.anchors.size() * config.noise_factors.size();
  std::vector<std::vector<Outcome>> outcomes(cells,
                                             std::vector<Outcome>(static_cast<std::size_t>(config.runs)));
  parallel_runs(config.runs, config.threads, [&](int run) {
    std::size_t cell = 0;
    for (const int anchors : config.anchors) {
      for (const double noise : config.noise_factors) {
        // The same stream for every cell of a run: same positions, anchor order and standard normals.
        std::mt19937_64 rng(run_seed(config.seed, run));
        GeometricGraphConfig world;
        world.nodes = config.nodes;
        world.radius = config.radius;
        world.anchors = anchors;
        world.noise_factor = noise;
        const SdpInstance instance = make_sdp_instance(world, rng);
        Outcome& o = outcomes[cell++][static_cast<std::size_t>(run)];
        o.usable = instance.sdp.usable();
        if (!o.usable) continue;
        o.inaccurate = instance.sdp.status == SdpStatus::kInaccurate;
        o.sdp = instance.sdp_error;
        const GradientRun refined = run_gradient_agents(instance.world, params);
        o.refined = refined.final_error;
        o.tau_end = refined.tau_end;
      }
    }
  });
  std::vector<TableTwoCell> table;
  std::size_t cell = 0;
  for (const int anchors : config.anchors) {
    for (const double noise : config.noise_factors) {
      TableTwoCell row;
      row.anchors = anchors;
      row.noise_factor = noise;
      std::vector<double> taus;
      for (const Outcome& o : outcomes[cell]) {
        if (!o.usable) {
          ++row.sdp_failures;
          continue;
        }
        ++row.runs;
        row.sdp_inaccurate += o.inaccurate ? 1 : 0;
        row.sdp_error += o.sdp;
        row.refined_error += o.refined;
        row.mean_tau_end += static_cast<double>(o.tau_end);
        taus.push_back(static_cast<double>(o.tau_end));
        row.refined_better += o.refined < o.sdp ? 1 : 0;
        row.tau_max_reached += o.tau_end >= params.max_updates ? 1 : 0;
      }
      if (row.runs > 0) {
        row.sdp_error /= row.runs;
        row.refined_error /= row.runs;
        row.mean_tau_end /= row.runs;
      }
      row.median_tau_end = median(taus);
      table.push_back(row);
      ++cell;
    }
  }
  return table;
}

std::vector<TableThreeColumn> run_table_three(const TableThreeConfig& config,
                                              const gradient::DgBbParams& params) {
  if (config.runs < 1) throw std::invalid_argument("table_three.runs: must be >= 1");
  std::vector<std::int64_t> skews{0};
  skews.insert(skews.end(), config.max_skews.begin(), config.max_skews.end());
  struct Outcome {
    bool usable = false;
    double sdp = 0.0;
    std::vector<GradientRun> refined;
  };
  std::vector<Outcome> outcomes(static_cast<std::size_t>(config.runs));
  parallel_runs(config.runs, config.threads, [&](int run) {
    std::mt19937_64 rng(run_seed(config.seed, run));
    GeometricGraphConfig world;
    world.nodes = config.nodes;
    world.radius = config.radius;
    world.anchors = config.anchors;
    world.noise_factor = config.noise_factor;
    const SdpInstance instance = make_sdp_instance(world, rng);
    Outcome& o = outcomes[static_cast<std::size_t>(run)];
    o.usable = instance.sdp.usable();
    if (!o.usable) return;
    o.sdp = instance.sdp_error;
    for (std::size_t k = 0; k < skews.size(); ++k) {
      // Start ticks from their own stream per (run, column): adding a column changes no other column.
      std::mt19937_64 ticks_rng(run_seed(config.seed ^ 0x5DEECE66DULL, run * 64 + static_cast<int>(k)));
      const auto ticks = draw_start_ticks(instance.world.truth.size(), skews[k], ticks_rng);
      o.refined.push_back(run_gradient_agents(instance.world, params, false,
                                              skews[k] > 0 ? ticks : std::vector<std::int64_t>{}));
    }
  });
  std::vector<TableThreeColumn> table(skews.size());
  for (std::size_t k = 0; k < skews.size(); ++k) {
    TableThreeColumn& column = table[k];
    column.max_skew = skews[k];
    std::vector<double> taus;
    for (const Outcome& o : outcomes) {
      if (!o.usable) {
        ++column.sdp_failures;
        continue;
      }
      ++column.runs;
      column.sdp_error += o.sdp;
      column.refined_error += o.refined[k].final_error;
      column.mean_tau_end += static_cast<double>(o.refined[k].tau_end);
      taus.push_back(static_cast<double>(o.refined[k].tau_end));
      column.mean_node_updates += o.refined[k].mean_node_updates;
      column.tau_max_reached += o.refined[k].tau_end >= params.max_updates ? 1 : 0;
    }
    if (column.runs > 0) {
      column.sdp_error /= column.runs;
      column.refined_error /= column.runs;
      column.mean_tau_end /= column.runs;
      column.mean_node_updates /= column.runs;
    }
    column.median_tau_end = median(taus);
  }
  return table;
}

}  // namespace swarmloc::research
