#include "swarmloc/research/gradient_figures.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "parallel_runs.hpp"
#include "swarmloc/core/random.hpp"

namespace swarmloc::research {

namespace gradient = estimators::gradient;

namespace {

/// The lattice of one run of one cell: the same draws for every method and T of that cell.
LatticeProblem cell_lattice(LatticeConfig config, int side, double initial_std, int run) {
  config.side = side;
  config.initial_std = initial_std;
  std::mt19937_64 rng(core::hash_keys(config.seed, side, std::llround(initial_std * 1e9), run));
  return make_lattice_problem(config, rng);
}

struct Method {
  std::string name;
  gradient::DgBbParams params;
};

std::vector<Method> convergence_methods(const gradient::DgBbParams& base) {
  std::vector<Method> methods(3, Method{"", base});
  methods[0].name = "Local BB (T = 0), eq. (15) as printed";
  methods[0].params.rule = gradient::StepRule::kLocalBb;
  methods[0].params.own_move_curvature = true;
  methods[1].name = "DG-BB, T = " + std::to_string(base.consensus_rounds);
  methods[1].params.rule = gradient::StepRule::kConsensusBb;
  methods[2].name = "Fixed alpha = 0.1";
  methods[2].params.rule = gradient::StepRule::kFixed;
  methods[2].params.fixed_step = 0.1;
  return methods;
}

int spikes(const std::vector<double>& trace) {
  int count = 0;
  for (std::size_t k = 1; k < trace.size(); ++k) count += trace[k] > 1.1 * trace[k - 1] ? 1 : 0;
  return count;
}

}  // namespace

ConvergenceFiguresResult run_convergence_figures(const ConvergenceFiguresConfig& config,
                                                 const gradient::DgBbParams& base) {
  const auto traced =
      std::find(config.initial_stds.begin(), config.initial_stds.end(), config.traced_initial_std);
  if (config.lattice.runs < 1 || config.initial_stds.empty() || config.abs_tols.empty() ||
      traced == config.initial_stds.end())
    throw std::invalid_argument(
        "convergence_figures: runs >= 1, an abs_tol, and traced_initial_std among initial_stds");
  const auto traced_std = static_cast<int>(traced - config.initial_stds.begin());
  const std::vector<Method> methods = convergence_methods(base);
  const auto method_count = static_cast<int>(methods.size());
  const auto std_count = static_cast<int>(config.initial_stds.size());
  const int cells = static_cast<int>(config.abs_tols.size()) * std_count;  // (η, σ_I), η outer
  const int runs = config.lattice.runs;
  // One slot per (η, σ_I, method, run); the traced σ_I with the first η keeps its Φ trace.
  std::vector<GradientRun> results(static_cast<std::size_t>(cells * method_count * runs));
  auto slot_of = [&](int cell, int method, int run) { return (cell * method_count + method) * runs + run; };
  // The fixed step runs longest (up to τ_max): start those first so the pool ends evenly.
  std::vector<int> order(results.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = static_cast<int>(k);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return (a / runs) % method_count > (b / runs) % method_count; });
  detail::parallel_runs(static_cast<int>(order.size()), config.threads, [&](int slot) {
    const int k = order[static_cast<std::size_t>(slot)];
    const int run = k % runs;
    const int method = (k / runs) % method_count;
    const int cell = k / (runs * method_count);
    const double initial_std = config.initial_stds[static_cast<std::size_t>(cell % std_count)];
    gradient::DgBbParams params = methods[static_cast<std::size_t>(method)].params;
    params.abs_tol = config.abs_tols[static_cast<std::size_t>(cell / std_count)];
    const LatticeProblem lattice = cell_lattice(config.lattice, config.lattice.side, initial_std, run);
    results[static_cast<std::size_t>(k)] = run_gradient_agents(lattice, params, cell == traced_std);
  });

  ConvergenceFiguresResult out;
  for (int m = 0; m < method_count; ++m) {
    ConvergenceCurve curve;
    curve.method = methods[static_cast<std::size_t>(m)].name;
    curve.mean_error.assign(config.trace_taus.size(), 0.0);
    for (int run = 0; run < runs; ++run) {
      const auto& trace = results[static_cast<std::size_t>(slot_of(traced_std, m, run))].error_trace;
      curve.spikes_per_run += static_cast<double>(spikes(trace)) / runs;
      for (std::size_t k = 0; k < config.trace_taus.size(); ++k) {
        // error_trace[τ − 1] is Φ after update τ; past the end the run had stopped with its last Φ.
        const auto tau = static_cast<std::size_t>(std::max<std::int64_t>(1, config.trace_taus[k]));
        const double phi =
            trace.empty() ? std::numeric_limits<double>::quiet_NaN() : trace[std::min(tau, trace.size()) - 1];
        curve.mean_error[k] += phi / runs;
      }
    }
    out.curves.push_back(curve);
  }
  for (int cell = 0; cell < cells; ++cell) {
    for (int m = 0; m < method_count; ++m) {
      ConvergenceCell c;
      c.method = methods[static_cast<std::size_t>(m)].name;
      c.initial_std = config.initial_stds[static_cast<std::size_t>(cell % std_count)];
      c.abs_tol = config.abs_tols[static_cast<std::size_t>(cell / std_count)];
      for (int run = 0; run < runs; ++run) {
        const GradientRun& r = results[static_cast<std::size_t>(slot_of(cell, m, run))];
        c.fraction_converged += (r.converged ? 1.0 : 0.0) / runs;
        c.mean_tau_end += static_cast<double>(r.tau_end) / runs;
      }
      out.cells.push_back(c);
    }
  }
  return out;
}

std::vector<ScalingCell> run_scaling_figures(const ScalingFiguresConfig& config,
                                             const gradient::DgBbParams& base) {
  if (config.lattice.runs < 1 || config.abs_tols.empty())
    throw std::invalid_argument("scaling_figures: runs >= 1 and at least one abs_tol");
  std::vector<ScalingCell> cells;
  std::vector<int> sides;
  auto add_cell = [&](int side, int consensus_rounds, double abs_tol) {
    ScalingCell cell{side * side, consensus_rounds, abs_tol};
    cell.initial_std = config.initial_std_per_spacing > 0.0
                           ? config.initial_std_per_spacing * (1.0 / (side - 1))
                           : config.lattice.initial_std;
    cells.push_back(cell);
    sides.push_back(side);
  };
  for (const double abs_tol : config.abs_tols) {
    for (const int side : config.sides) {
      for (const int t : config.consensus_rounds) add_cell(side, t, abs_tol);
    }
    for (const int side : config.sides_at_t20) add_cell(side, 20, abs_tol);
  }
  const int runs = config.lattice.runs;
  std::vector<GradientRun> results(cells.size() * static_cast<std::size_t>(runs));
  // Largest lattices and T first: they take longest, and the pool then ends evenly.
  std::vector<int> order(results.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = static_cast<int>(k);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    const auto& ca = cells[static_cast<std::size_t>(a / runs)];
    const auto& cb = cells[static_cast<std::size_t>(b / runs)];
    return ca.nodes * (ca.consensus_rounds + 1) > cb.nodes * (cb.consensus_rounds + 1);
  });
  detail::parallel_runs(static_cast<int>(order.size()), config.threads, [&](int slot) {
    const int k = order[static_cast<std::size_t>(slot)];
    const auto cell = static_cast<std::size_t>(k / runs);
    gradient::DgBbParams params = base;
    params.rule = gradient::StepRule::kConsensusBb;
    params.consensus_rounds = cells[cell].consensus_rounds;
    params.abs_tol = cells[cell].abs_tol;
    const LatticeProblem lattice =
        cell_lattice(config.lattice, sides[cell], cells[cell].initial_std, k % runs);
    results[static_cast<std::size_t>(k)] = run_gradient_agents(lattice, params);
  });
  for (std::size_t c = 0; c < cells.size(); ++c) {
    int converged = 0;
    for (int run = 0; run < runs; ++run) {
      const GradientRun& r = results[c * static_cast<std::size_t>(runs) + static_cast<std::size_t>(run)];
      cells[c].mean_tau_end += static_cast<double>(r.tau_end) / runs;
      cells[c].mean_final_error += r.final_error / runs;
      if (!r.converged) continue;
      ++converged;
      cells[c].mean_tau_end_converged += static_cast<double>(r.tau_end);
    }
    cells[c].fraction_converged = static_cast<double>(converged) / runs;
    cells[c].mean_tau_end_converged = converged > 0 ? cells[c].mean_tau_end_converged / converged
                                                    : std::numeric_limits<double>::quiet_NaN();
  }
  return cells;
}

}  // namespace swarmloc::research
