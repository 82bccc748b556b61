// One Calafiore et al. Table I lattice run (10 × 10, both diagonals, noiseless) over the in-process bus:
// DG-BB with T = 20 to convergence, and the fixed step (one STATE exchange per update) for 2000 updates.
#include <benchmark/benchmark.h>

#include <random>

#include "swarmloc/research/gradient_localization.hpp"

namespace {

namespace experiments = swarmloc::research;
namespace gradient = swarmloc::estimators::gradient;

experiments::LatticeProblem table_one_lattice() {
  experiments::LatticeConfig config;
  config.both_diagonals = true;
  std::mt19937_64 rng(1);
  return experiments::make_lattice_problem(config, rng);
}

void dgbb_lattice_run(benchmark::State& state) {
  const experiments::LatticeProblem lattice = table_one_lattice();
  gradient::DgBbParams params;
  params.consensus_rounds = 20;
  params.abs_tol = 1e-10;
  for (auto _ : state) {
    experiments::GradientRun run = experiments::run_gradient_agents(lattice, params);
    benchmark::DoNotOptimize(run);
  }
}
BENCHMARK(dgbb_lattice_run)->Unit(benchmark::kMillisecond);

void fixed_step_lattice_2000_updates(benchmark::State& state) {
  const experiments::LatticeProblem lattice = table_one_lattice();
  gradient::DgBbParams params;
  params.rule = gradient::StepRule::kFixed;
  params.fixed_step = 0.01;
  params.abs_tol = 1e-10;
  params.max_updates = 2000;
  for (auto _ : state) {
    experiments::GradientRun run = experiments::run_gradient_agents(lattice, params);
    benchmark::DoNotOptimize(run);
  }
}
BENCHMARK(fixed_step_lattice_2000_updates)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
