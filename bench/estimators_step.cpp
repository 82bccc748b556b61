// One IEIF / IEKF / dml step with 8 neighbours, one multipath BP step with 8 neighbours (Leng et al.'s
// beliefs and exact GaBP), and one CRLB build at N = 30 and N = 300.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "kalman_reference.hpp"
#include "swarmloc/estimators/bp/multipath_bp.hpp"
#include "swarmloc/estimators/crlb.hpp"
#include "swarmloc/estimators/dml/dml.hpp"
#include "swarmloc/estimators/kalman/ieif.hpp"
#include "swarmloc/estimators/kalman/iekf.hpp"
#include "swarmloc/models/multipath.hpp"

namespace {

using swarmloc::AgentId;
using swarmloc::Mat2;
using swarmloc::Vec2;
namespace est = swarmloc::estimators;

struct Neighbourhood {
  est::Inbox inbox;
  est::MeasurementBatch batch;
};

Neighbourhood eight_neighbours() {
  Neighbourhood n;
  const Vec2 self(10.0, 10.0);
  for (int j = 1; j <= 8; ++j) {
    const double angle = 0.785 * j;
    const Vec2 x_j = self + 5.0 * Vec2(std::cos(angle), std::sin(angle));
    est::StateMessage state;
    state.mean_m = x_j;
    state.covariance = 0.01 * Mat2::Identity();
    state.anchor = j <= 3;
    state.degree = 8;
    n.inbox.states.push_back(est::Received<est::StateMessage>{j, 0, state});
    n.batch.ranges.push_back(est::RangeMeasurement{j, 5.02, 0.1});
  }
  return n;
}

template <typename Filter>
void filter_step_8_neighbours(benchmark::State& state) {
  const Neighbourhood n = eight_neighbours();
  est::AgentSetup setup;
  setup.initial_guess_m = Vec2(10.3, 9.8);
  Filter filter(setup, est::KalmanFilterParams{});
  std::int64_t k = 1;
  for (auto _ : state) {
    est::StepOutput out = filter.step(est::StepInput{k++, &n.batch, &n.inbox});
    benchmark::DoNotOptimize(out);
  }
}
BENCHMARK_TEMPLATE(filter_step_8_neighbours, est::Ieif);
BENCHMARK_TEMPLATE(filter_step_8_neighbours, est::Iekf);
BENCHMARK_TEMPLATE(filter_step_8_neighbours, est::Dml);

/// The IEIF step with algorithm.update_iterations = Arg (1: Gasparri & Pascucci's single linearization).
void ieif_step_8_neighbours_update_iterations(benchmark::State& state) {
  const Neighbourhood n = eight_neighbours();
  est::AgentSetup setup;
  setup.initial_guess_m = Vec2(10.3, 9.8);
  est::KalmanFilterParams params;
  params.update_iterations = static_cast<int>(state.range(0));
  est::Ieif filter(setup, params);
  std::int64_t k = 1;
  for (auto _ : state) {
    est::StepOutput out = filter.step(est::StepInput{k++, &n.batch, &n.inbox});
    benchmark::DoNotOptimize(out);
  }
}
BENCHMARK(ieif_step_8_neighbours_update_iterations)->Arg(1)->Arg(10);

/// One multipath BP iteration at a node with 8 neighbours, two reflected paths each (walls at 0° and 45°),
/// after the paths arrived; Arg 0: Leng et al.'s beliefs, 1: exact GaBP (each neighbour lists its
/// contributions).
void multipath_bp_step_8_neighbours(benchmark::State& state) {
  const bool exact = state.range(0) == 1;
  const Vec2 self(10.0, 10.0);
  const swarmloc::models::Wall walls[] = {{Vec2(10.0, -8.0), 0.0}, {Vec2(30.0, 0.0), 0.785398}};
  est::MeasurementBatch batch;
  est::Inbox inbox;
  for (int j = 1; j <= 8; ++j) {
    const double angle = 0.785 * j + 0.1;
    const Vec2 s_j = self + 5.0 * Vec2(std::cos(angle), std::sin(angle));
    for (int r = 0; r < 2; ++r) {
      const auto path = swarmloc::models::reflect_path(self, s_j, walls[r]);
      batch.paths.push_back({j, r, path->length_m + 0.01 * j, path->theta_ji_rad, path->theta_ij_rad});
    }
    est::BeliefMessage belief;
    belief.mean_m = s_j + Vec2(0.05, -0.02);
    belief.information = Mat2::Identity() * (4.0 + j);
    if (exact)
      belief.contributions = {{0, Mat2::Identity(), Vec2(10.0, 10.0)}, {j + 10, Mat2::Identity(), s_j}};
    inbox.beliefs.push_back(est::Received<est::BeliefMessage>{j, 0, belief});
  }
  est::bp::MultipathBpParams params;
  params.exact_messages = exact;
  est::bp::MultipathBp node(est::AgentSetup{}, params);
  (void)node.step(est::StepInput{0, &batch, &inbox});
  std::int64_t k = 1;
  for (auto _ : state) {
    est::StepOutput out = node.step(est::StepInput{k++, nullptr, &inbox});
    benchmark::DoNotOptimize(out);
  }
}
BENCHMARK(multipath_bp_step_8_neighbours)->Arg(0)->Arg(1);

void crlb_all_pairs(benchmark::State& state) {
  const auto n = static_cast<int>(state.range(0));
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> uniform(0.0, 30.0);
  std::vector<Vec2> truth;
  std::vector<bool> anchor;
  for (int i = 0; i < n; ++i) {
    truth.emplace_back(uniform(rng), uniform(rng));
    anchor.push_back(i < n / 4);
  }
  const auto ranges = est::mutual_range_observations(truth, anchor, 0.1);
  for (auto _ : state) {
    est::CrlbResult r = est::range_network_crlb(truth, anchor, ranges, 100.0);
    benchmark::DoNotOptimize(r);
  }
  state.counters["observations"] = static_cast<double>(ranges.size());
}
BENCHMARK(crlb_all_pairs)->Arg(30)->Arg(300)->Unit(benchmark::kMillisecond);

/// One IEKF measurement update with M ranges: Gasparri & Pascucci Table II has every pair measuring, M = N
/// − 1.
est::Linearization ranges_rows(Eigen::Index m) {
  std::mt19937_64 rng(2);
  std::normal_distribution<double> normal(0.0, 1.0);
  est::Linearization rows;
  rows.jacobian.resize(m, 2);
  rows.innovation.resize(m);
  rows.variance.resize(m);
  for (Eigen::Index k = 0; k < m; ++k) {
    rows.jacobian.row(k) = Vec2(normal(rng), normal(rng)).normalized().transpose();
    rows.innovation(k) = 0.1 * normal(rng);
    rows.variance(k) = 0.01 + 0.001 * std::abs(normal(rng));
  }
  return rows;
}

void iekf_update_two_by_two(benchmark::State& state) {
  const est::Linearization rows = ranges_rows(state.range(0));
  const Mat2 P{{0.5, 0.1}, {0.1, 0.4}};
  for (auto _ : state) benchmark::DoNotOptimize(est::kalman_update(Vec2(1.0, 2.0), P, rows));
}
void iekf_update_m_by_m(benchmark::State& state) {
  const est::Linearization rows = ranges_rows(state.range(0));
  const Mat2 P{{0.5, 0.1}, {0.1, 0.4}};
  for (auto _ : state) {
    benchmark::DoNotOptimize(swarmloc::testing::kalman_update_innovation_form(Vec2(1.0, 2.0), P, rows));
  }
}
BENCHMARK(iekf_update_two_by_two)->Arg(8)->Arg(89)->Arg(359);
BENCHMARK(iekf_update_m_by_m)->Arg(8)->Arg(89)->Arg(359);

}  // namespace

BENCHMARK_MAIN();
