#include "swarmloc/research/gradient_localization.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>

#include "sync_bus.hpp"

namespace swarmloc::research {

namespace gradient = estimators::gradient;

LatticeProblem make_lattice_problem(const LatticeConfig& c, std::mt19937_64& rng) {
  if (c.side < 2) throw std::invalid_argument("lattice.side: must be >= 2");
  const int n = c.side * c.side;
  LatticeProblem lattice;
  auto index = [&](int r, int col) { return r * c.side + col; };
  const double spacing = 1.0 / (c.side - 1);
  lattice.truth.resize(static_cast<std::size_t>(n));
  lattice.problem.anchor.assign(static_cast<std::size_t>(n), false);
  for (int r = 0; r < c.side; ++r) {
    for (int col = 0; col < c.side; ++col)
      lattice.truth[static_cast<std::size_t>(index(r, col))] = Vec2(col * spacing, r * spacing);
  }
  for (const int k :
       {index(0, 0), index(0, c.side - 1), index(c.side - 1, 0), index(c.side - 1, c.side - 1)}) {
    lattice.problem.anchor[static_cast<std::size_t>(k)] = true;
  }
  std::normal_distribution<double> normal(0.0, 1.0);
  auto add_edge = [&](int i, int j) {
    const double d =
        (lattice.truth[static_cast<std::size_t>(i)] - lattice.truth[static_cast<std::size_t>(j)]).norm();
    const double noisy = std::abs(d + c.noise_factor * d * normal(rng));  // Calafiore et al. eq. (16)
    lattice.problem.edges.push_back(gradient::RangeEdge{i, j, c.noise_factor > 0.0 ? noisy : d});
  };
  for (int r = 0; r < c.side; ++r) {
    for (int col = 0; col < c.side; ++col) {
      if (col + 1 < c.side) add_edge(index(r, col), index(r, col + 1));
      if (r + 1 < c.side) add_edge(index(r, col), index(r + 1, col));
      if (r + 1 < c.side && col + 1 < c.side) add_edge(index(r, col), index(r + 1, col + 1));
      if (c.both_diagonals && r + 1 < c.side && col > 0) add_edge(index(r, col), index(r + 1, col - 1));
    }
  }
  lattice.problem.initial = lattice.truth;
  for (std::size_t i = 0; i < lattice.truth.size(); ++i) {
    if (lattice.problem.anchor[i]) continue;
    const double x = normal(rng);
    lattice.problem.initial[i] += c.initial_std * Vec2(x, normal(rng));
  }
  return lattice;
}

namespace {

double global_error(const LatticeProblem& lattice, const std::vector<const gradient::DgBb*>& agents) {
  double sum = 0.0;
  for (std::size_t i = 0; i < agents.size(); ++i) sum += (agents[i]->position() - lattice.truth[i]).norm();
  return sum / static_cast<double>(agents.size());
}

/// The last start tick; throws unless start_ticks is empty or one tick >= 0 per node.
std::int64_t last_start_tick(const std::vector<std::int64_t>& start_ticks, std::size_t n) {
  if (!start_ticks.empty() && start_ticks.size() != n)
    throw std::invalid_argument("run_gradient_agents: start_ticks must have one entry per node");
  std::int64_t last_start = 0;
  for (const std::int64_t tick : start_ticks) {
    if (tick < 0) throw std::invalid_argument("run_gradient_agents: start ticks must be >= 0");
    last_start = std::max(last_start, tick);
  }
  return last_start;
}

/// The statistics of a finished run: updates, source rounds, final error and safeguard counts.
void finish_gradient_run(GradientRun& run, const LatticeProblem& lattice, const gradient::DgBbParams& params,
                         const std::vector<const gradient::DgBb*>& nodes) {
  int unknowns = 0;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    if (lattice.problem.anchor[i]) continue;
    run.mean_node_updates += static_cast<double>(nodes[i]->updates());
    ++unknowns;
  }
  if (unknowns > 0) run.mean_node_updates /= unknowns;
  const bool consensus = params.rule == gradient::StepRule::kConsensusBb && params.consensus_rounds > 0;
  run.source_rounds = consensus ? run.tau_end * params.consensus_rounds : run.tau_end;
  run.final_error = global_error(lattice, nodes);
  run.converged = run.final_error < 1e-3;
  for (const auto* node : nodes) {
    run.safeguard_fires += node->safeguard_count();
    run.trust_region_fires += node->trust_region_count();
  }
}

}  // namespace

GradientRun run_gradient_agents(const LatticeProblem& lattice, const gradient::DgBbParams& params,
                                bool record_trace, const std::vector<std::int64_t>& start_ticks) {
  const auto n = lattice.truth.size();
  const std::int64_t last_start = last_start_tick(start_ticks, n);
  auto start_of = [&](std::size_t i) { return start_ticks.empty() ? std::int64_t{0} : start_ticks[i]; };
  detail::Adjacency adjacency(n);
  std::vector<estimators::MeasurementBatch> batches(n);
  for (const auto& e : lattice.problem.edges) {
    adjacency[static_cast<std::size_t>(e.i)].push_back(e.j);
    adjacency[static_cast<std::size_t>(e.j)].push_back(e.i);
    batches[static_cast<std::size_t>(e.i)].ranges.push_back({e.j, e.range_m, 0.0});
    batches[static_cast<std::size_t>(e.j)].ranges.push_back({e.i, e.range_m, 0.0});
  }
  std::vector<std::unique_ptr<estimators::Estimator>> agents;
  std::vector<const gradient::DgBb*> nodes;
  for (std::size_t i = 0; i < n; ++i) {
    estimators::AgentSetup setup;
    setup.id = static_cast<AgentId>(i);
    setup.anchor = lattice.problem.anchor[i];
    setup.initial_guess_m = lattice.problem.initial[i];
    auto agent = std::make_unique<gradient::DgBb>(setup, params);
    nodes.push_back(agent.get());
    agents.push_back(std::move(agent));
  }
  detail::SyncBus bus(adjacency);
  std::vector<bool> awake(n, false);
  std::vector<const estimators::MeasurementBatch*> now(n, nullptr);
  GradientRun run;
  const std::int64_t per_update =
      params.rule == gradient::StepRule::kConsensusBb ? params.consensus_rounds + 1 : 1;
  const std::int64_t max_rounds = last_start + (params.max_updates + 2) * per_update + 2;
  std::int64_t last_tau = 0;
  auto tau_now = [&] {
    std::int64_t tau = 0;
    for (const auto* node : nodes) tau = std::max(tau, node->updates());
    return tau;
  };
  for (std::int64_t round = 0; round < max_rounds; ++round) {
    // Nodes starting now: their initial STATE reaches the neighbours before this round's step (with every
    // start at 0 this is the synchronous start), their ranges arrive with their first step.
    std::fill(now.begin(), now.end(), nullptr);
    for (std::size_t i = 0; i < n; ++i) {
      if (awake[i] || start_of(i) != round) continue;
      awake[i] = true;
      bus.deliver(static_cast<int>(i), round - 1, agents[i]->initial_outbox());
      now[i] = &batches[i];
    }
    bus.round(agents, round, now, &awake);
    ++run.rounds;
    if (record_trace) {
      const std::int64_t tau = tau_now();
      if (tau > last_tau) {
        run.error_trace.push_back(global_error(lattice, nodes));
        last_tau = tau;
      }
    }
    const bool any_active =
        std::any_of(nodes.begin(), nodes.end(), [](const auto* node) { return node->active(); });
    if (!any_active) break;
  }
  run.tau_end = tau_now();
  finish_gradient_run(run, lattice, params, nodes);
  return run;
}

std::vector<TableOneRow> run_table_one(const LatticeConfig& config, const gradient::DgBbParams& base) {
  struct Method {
    std::string name;
    gradient::DgBbParams params;
  };
  std::vector<Method> methods;
  auto with = [&](const std::string& name, gradient::StepRule rule, double fixed_step) {
    gradient::DgBbParams p = base;
    p.rule = rule;
    p.fixed_step = fixed_step;
    methods.push_back(Method{name, p});
  };
  with("DG-BB, T = " + std::to_string(base.consensus_rounds), gradient::StepRule::kConsensusBb,
       base.fixed_step);
  with("Local BB (T = 0)", gradient::StepRule::kLocalBb, base.fixed_step);
  with("Fixed alpha = 0.1", gradient::StepRule::kFixed, 0.1);
  with("Fixed alpha = 0.01", gradient::StepRule::kFixed, 0.01);
  with("Step length k = 10/sqrt(tau)", gradient::StepRule::kStepLength, base.fixed_step);
  methods.back().params.step_length = 10.0;
  methods.back().params.schedule = gradient::StepLengthSchedule::kOverSqrtTau;
  // Eq. (15) as printed: ΔD_i from node i's own move, the neighbours where they are now (the row above
  // takes [E-6], the change of ∇_i f(p) with the neighbours' moves in it).
  with("Local BB (T = 0), eq. (15) as printed: own move", gradient::StepRule::kLocalBb, base.fixed_step);
  methods.back().params.own_move_curvature = true;
  // Not in the source: the BB trust region (DgBbParams::max_move_fraction), which the runtime uses.
  if (base.max_move_fraction == 0.0) {
    with("DG-BB, T = " + std::to_string(base.consensus_rounds) + ", trust region 1",
         gradient::StepRule::kConsensusBb, base.fixed_step);
    methods.back().params.max_move_fraction = 1.0;
    with("Local BB (T = 0), trust region 1", gradient::StepRule::kLocalBb, base.fixed_step);
    methods.back().params.max_move_fraction = 1.0;
  }

  std::vector<TableOneRow> rows(methods.size());
  for (std::size_t m = 0; m < methods.size(); ++m) rows[m].method = methods[m].name;
  std::mt19937_64 rng(config.seed);
  for (int run = 0; run < config.runs; ++run) {
    const LatticeProblem lattice = make_lattice_problem(config, rng);
    for (std::size_t m = 0; m < methods.size(); ++m) {
      const GradientRun r = run_gradient_agents(lattice, methods[m].params);
      const double w = 1.0 / config.runs;
      rows[m].mean_tau_end += w * static_cast<double>(r.tau_end);
      rows[m].mean_rounds += w * static_cast<double>(r.rounds);
      rows[m].mean_source_rounds += w * static_cast<double>(r.source_rounds);
      rows[m].fraction_converged += w * (r.converged ? 1.0 : 0.0);
      rows[m].mean_final_error += w * r.final_error;
      rows[m].fraction_at_tau_max += w * (r.tau_end >= methods[m].params.max_updates ? 1.0 : 0.0);
      rows[m].mean_trust_region_fires += w * r.trust_region_fires;
    }
  }
  return rows;
}

}  // namespace swarmloc::research
