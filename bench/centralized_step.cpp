// One centralized filter step (EKF, LB-EKF with Alg. 1, LB-EKF with the O(nL²) inversion, LB-EKF-I)
// and one BandInv_L call, Khan et al. Secs. 4–5 (docs/algorithms.md §2.6). Agents are placed uniformly in a
// 40 m-high corridor at the E-A2 density (30 agents per 40 m × 40 m), so the VR bandwidth stays near
// the E-A2 value as N grows; relabeled by Khan et al. Alg. 3 on the true positions; L = 20.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <random>

#include "swarmloc/estimators/centralized/band_inversion.hpp"
#include "swarmloc/estimators/centralized/centralized_filter.hpp"
#include "swarmloc/estimators/centralized/relabeling.hpp"

namespace {

namespace cen = swarmloc::estimators::centralized;
using swarmloc::Mat2;
using swarmloc::MatX;
using swarmloc::Vec2;
using swarmloc::VecX;

constexpr double kRadius = 15.0;
constexpr int kBandwidth = 20;

struct Network {
  VecX initial_mean;
  std::vector<Mat2> initial_cov;
  std::vector<int> labels;
  cen::CentralizedMeasurements measurements;
};

Network make_network(int agents) {
  std::mt19937_64 rng(static_cast<std::uint64_t>(agents));
  const double length = 40.0 * agents / 30.0;
  std::uniform_real_distribution<double> ux(0.0, length);
  std::uniform_real_distribution<double> uy(0.0, 40.0);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<Vec2> truth;
  for (int a = 0; a < agents; ++a) truth.emplace_back(ux(rng), uy(rng));
  Network net;
  net.labels = cen::lexicographic_labels(truth);
  const std::vector<int> order = cen::inverse_labels(net.labels);
  net.initial_mean.resize(2 * agents);
  for (int a = 0; a < agents; ++a) {
    net.initial_mean.segment<2>(2 * a) = truth[static_cast<std::size_t>(a)] + 2.2 * Vec2(g(rng), g(rng));
    net.initial_cov.push_back(5.0 * Mat2::Identity());
    if (a % 4 == 0) {
      net.measurements.beacon_fixes.emplace_back(
          a, truth[static_cast<std::size_t>(a)] + 1.4 * Vec2(g(rng), g(rng)));
    }
  }
  // Disk graph by an x-sorted sweep (O(N · strip)).
  for (std::size_t p = 0; p < order.size(); ++p) {
    const Vec2& xi = truth[static_cast<std::size_t>(order[p])];
    for (std::size_t q = p + 1; q < order.size(); ++q) {
      const Vec2& xj = truth[static_cast<std::size_t>(order[q])];
      if (xj.x() - xi.x() > kRadius) break;
      const double rho = (xi - xj).norm();
      if (rho <= kRadius) net.measurements.ranges.push_back({order[p], order[q], rho + 3.16 * g(rng)});
    }
  }
  return net;
}

void centralized_step(benchmark::State& state, cen::CentralizedKind kind, cen::BandInversionMethod method) {
  const int agents = static_cast<int>(state.range(0));
  const Network net = make_network(agents);
  cen::CentralizedFilterParams params;
  params.bandwidth = kBandwidth;
  params.inversion = method;
  params.labels = net.labels;
  const auto filter = cen::make_centralized_filter(kind, net.initial_mean, net.initial_cov, params);
  filter->step(net.measurements);  // leave the k = 0 special case out of the timing
  for (auto _ : state) {
    filter->step(net.measurements);
    benchmark::DoNotOptimize(filter->agent_mean(0));
  }
  state.counters["agents"] = agents;
  state.counters["edges"] = static_cast<double>(net.measurements.ranges.size());
  state.counters["bandwidth_S"] = filter->last_measurement_bandwidth();
}

void ekf_step(benchmark::State& state) {
  centralized_step(state, cen::CentralizedKind::kEkf, cen::BandInversionMethod::kWindows);
}
void lb_ekf_alg1_step(benchmark::State& state) {
  centralized_step(state, cen::CentralizedKind::kLbEkf, cen::BandInversionMethod::kWindows);
}
void lb_ekf_sliding_step(benchmark::State& state) {
  centralized_step(state, cen::CentralizedKind::kLbEkf, cen::BandInversionMethod::kSlidingCholesky);
}
void lb_ekf_i_sliding_step(benchmark::State& state) {
  centralized_step(state, cen::CentralizedKind::kLbEkfI, cen::BandInversionMethod::kSlidingCholesky);
}

BENCHMARK(ekf_step)->Arg(30)->Arg(300)->Unit(benchmark::kMillisecond);
BENCHMARK(ekf_step)->Arg(1000)->Arg(3000)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(lb_ekf_alg1_step)->Arg(30)->Arg(300)->Arg(3000)->Arg(30000)->Unit(benchmark::kMillisecond);
BENCHMARK(lb_ekf_sliding_step)
    ->Arg(30)
    ->Arg(300)
    ->Arg(3000)
    ->Arg(30000)
    ->Arg(100000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(lb_ekf_i_sliding_step)->Arg(30)->Arg(300)->Arg(3000)->Arg(30000)->Unit(benchmark::kMillisecond);

// BandInv_L on an SPD band matrix of size n with bandwidth 2L (so the output truncates), L = 20.
cen::BandMatrix random_band(int n, int bandwidth) {
  std::mt19937_64 rng(static_cast<std::uint64_t>(n));
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  cen::BandMatrix a(n, bandwidth);
  for (int j = 0; j < n; ++j) {
    for (int i = j + 1; i <= std::min(n - 1, j + bandwidth); ++i) a.ref(i, j) = u(rng);
  }
  a.add_diagonal(2.0 * bandwidth + 1.0);
  return a;
}

void band_inverse_bench(benchmark::State& state, cen::BandInversionMethod method) {
  const int n = static_cast<int>(state.range(0));
  const cen::BandMatrix a = random_band(n, 2 * kBandwidth);
  for (auto _ : state) benchmark::DoNotOptimize(cen::band_inverse(a, kBandwidth, method).storage().data());
  state.counters["n"] = n;
}
void band_inverse_alg1(benchmark::State& state) {
  band_inverse_bench(state, cen::BandInversionMethod::kWindows);
}
void band_inverse_sliding(benchmark::State& state) {
  band_inverse_bench(state, cen::BandInversionMethod::kSlidingCholesky);
}
BENCHMARK(band_inverse_alg1)->Arg(30000)->Arg(60000)->Unit(benchmark::kMillisecond);
BENCHMARK(band_inverse_sliding)->Arg(30000)->Arg(60000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
