#include "reproduce.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "swarmloc/research/centralized_experiments.hpp"
#include "swarmloc/research/gradient_figures.hpp"
#include "swarmloc/research/gradient_localization.hpp"
#include "swarmloc/research/multipath_localization.hpp"
#include "swarmloc/research/relative_localization.hpp"
#include "swarmloc/research/sdp_refinement.hpp"
#include "swarmloc/sim/simulator.hpp"

namespace swarmloc::orchestrator {
namespace {

namespace cen = estimators::centralized;

int resolve_threads(int threads) {
  return threads > 0 ? threads : static_cast<int>(std::max(1U, std::thread::hardware_concurrency()));
}

/// Runs fn(trial) for trial in [0, trials) on `threads` threads.
template <typename Fn>
void parallel_trials(int trials, int threads, Fn&& fn) {
  std::atomic<int> next{0};
  std::vector<std::thread> pool;
  for (int k = 0; k < resolve_threads(threads); ++k) {
    pool.emplace_back([&] {
      for (int t = next++; t < trials; t = next++) fn(t);
    });
  }
  for (auto& thread : pool) thread.join();
}

void emit(const std::filesystem::path& out_dir, const std::string& name, const std::string& markdown) {
  std::filesystem::create_directories(out_dir);
  std::ofstream(out_dir / (name + ".md")) << markdown;
  std::printf("%s\n(written to %s)\n", markdown.c_str(), (out_dir / (name + ".md")).c_str());
}

std::string fmt(const char* format, double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, value);
  return buffer;
}

// ---------------- 000 E-A1 ----------------
int reproduce_ea1(const ReproduceOptions& options) {
  const int n = 500;
  const std::vector<int> a_bandwidths{5, 10, 20};
  std::vector<int> ls;
  for (int l = 0; l <= 50; l += 5) ls.push_back(l);
  std::ostringstream md;
  md << "# E-A1 — banded inversion error ‖A⁻¹ − BandInv_L(A)‖_F (000 Fig. 2)\n\n"
     << "n = 500, in-band entries U(−1, 1), diagonal 15, normalized by the largest entry; seed "
     << options.seed
     << ". The paper gives a figure, no numbers: error falls steeply until L exceeds the bandwidth of A, "
        "then "
        "slowly to 0 (exact at L = n − 1).\n\n| L |";
  for (int b : a_bandwidths) md << " bandwidth(A) = " << b << " |";
  md << "\n|---|";
  for (std::size_t k = 0; k < a_bandwidths.size(); ++k) md << "---|";
  md << "\n";
  std::vector<std::vector<double>> errors;
  for (int b : a_bandwidths) {
    std::mt19937_64 rng(options.seed * 1000 + static_cast<std::uint64_t>(b));
    errors.push_back(cen::banded_inversion_errors(n, b, ls, rng));
  }
  for (std::size_t i = 0; i < ls.size(); ++i) {
    md << "| " << ls[i] << " |";
    for (const auto& column : errors) md << ' ' << fmt("%.3e", column[i]) << " |";
    md << "\n";
  }
  emit(options.out_dir, "ea1", md.str());
  return 0;
}

// ---------------- 000 E-A2 ----------------
int reproduce_ea2(const ReproduceOptions& options) {
  const int trials = options.trials > 0 ? options.trials : 1000;
  cen::Ea2Config config;
  config.config_seed = options.seed + 2;
  const auto world = cen::make_ea2_world(config);
  const std::vector<std::pair<cen::Ea2Variant, std::string>> variants{
      {cen::Ea2Variant::kEkf, "EKF"},
      {cen::Ea2Variant::kLbEkfVr, "LB-EKF+VR (L=20)"},
      {cen::Ea2Variant::kLbEkfNoVr, "LB-EKF without VR (L=20)"},
      {cen::Ea2Variant::kLbEkfIVr, "LB-EKF-I+VR (L=20)"}};
  const auto steps = static_cast<std::size_t>(config.steps);
  const auto agents = static_cast<Eigen::Index>(config.num_agents);
  struct Sums {
    std::vector<double> total;
    MatX agent;
  };
  std::vector<Sums> sums(variants.size(), Sums{std::vector<double>(steps, 0.0),
                                               MatX::Zero(static_cast<Eigen::Index>(steps), agents)});
  std::vector<double> crb_total(steps, 0.0);
  MatX crb_agent = MatX::Zero(static_cast<Eigen::Index>(steps), agents);
  std::mutex mutex;
  const auto started = std::chrono::steady_clock::now();
  parallel_trials(trials, options.threads, [&](int t) {
    std::vector<cen::Ea2TrialResult> results;
    for (const auto& [variant, name] : variants) {
      auto cfg = config;
      cfg.compute_crb = (variant == cen::Ea2Variant::kEkf);
      results.push_back(
          cen::run_ea2_trial(cfg, world, variant, options.seed * 100000 + static_cast<std::uint64_t>(t)));
    }
    const std::lock_guard<std::mutex> lock(mutex);
    for (std::size_t v = 0; v < variants.size(); ++v) {
      for (std::size_t k = 0; k < steps; ++k) sums[v].total[k] += results[v].total_mse[k];
      sums[v].agent += results[v].agent_mse;
    }
    for (std::size_t k = 0; k < steps; ++k) crb_total[k] += results[0].crb_total[k];
    crb_agent += results[0].crb_agent;
  });
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  const double n = trials;
  std::vector<bool> beacon(static_cast<std::size_t>(config.num_agents), false);
  for (int b : world.beacons) beacon[static_cast<std::size_t>(b)] = true;
  auto steady = [&](const std::vector<double>& series) {
    double sum = 0.0;
    for (std::size_t k = 50; k < steps; ++k) sum += series[k];
    return sum / static_cast<double>(steps - 50) / n;
  };
  auto agent_mean = [&](const MatX& agent,
                        bool beacons) {  // steady-state per-agent MSE, averaged over the group
    double sum = 0.0;
    int count = 0;
    for (Eigen::Index i = 0; i < agents; ++i) {
      if (beacon[static_cast<std::size_t>(i)] != beacons) continue;
      sum += agent.block(50, i, static_cast<Eigen::Index>(steps) - 50, 1).mean() / n;
      ++count;
    }
    return sum / count;
  };
  std::ostringstream md;
  md << "# E-A2 — EKF vs LB-EKF with and without vertex relabeling (000 Figs. 4–6)\n\n"
     << trials
     << " Monte Carlo trials on one fixed configuration (30 agents, 8 beacons, 40 m × 40 m, r = 15 m, "
     << "σ_q = 2 m², σ_r = 10 m², σ_p = 0.02 m², Σ_0 = 5 I, 100 steps); configuration seed "
     << config.config_seed << ", trial seeds " << options.seed * 100000 << "+t. Wall time "
     << fmt("%.1f", wall_s) << " s on " << resolve_threads(options.threads) << " threads.\n\n"
     << "Graph bandwidth: " << world.natural_bandwidth << " in generation order, " << world.vr_bandwidth
     << " after relabeling x(0) (paper: 8; uniform draws give 11–16, so the configuration is drawn until "
        "β_VR ≤ "
     << config.max_vr_bandwidth << ", " << world.attempts << " draws).\n\n"
     << "| filter | total MSE, steady state (k ≥ 50) [m²] | total MSE k = 10 | total MSE k = 99 | per-agent "
        "MSE, non-beacons [m²] | per-agent MSE, beacons [m²] | vs EKF (steady) |\n"
     << "|---|---|---|---|---|---|---|\n";
  const double ekf_steady = steady(sums[0].total);
  for (std::size_t v = 0; v < variants.size(); ++v) {
    md << "| " << variants[v].second << " | " << fmt("%.3f", steady(sums[v].total)) << " | "
       << fmt("%.3f", sums[v].total[10] / n) << " | " << fmt("%.3f", sums[v].total[99] / n) << " | "
       << fmt("%.4f", agent_mean(sums[v].agent, false)) << " | "
       << fmt("%.4f", agent_mean(sums[v].agent, true)) << " | "
       << fmt("%.3f", steady(sums[v].total) / ekf_steady) << " |\n";
  }
  md << "| posterior CRB (tr J_k⁻¹) | " << fmt("%.3f", steady(crb_total)) << " | "
     << fmt("%.3f", crb_total[10] / n) << " | " << fmt("%.3f", crb_total[99] / n) << " | "
     << fmt("%.4f", agent_mean(crb_agent, false)) << " | " << fmt("%.4f", agent_mean(crb_agent, true))
     << " | " << fmt("%.3f", steady(crb_total) / ekf_steady) << " |\n\n"
     << "Paper (figures only): LB-EKF+VR close to the EKF in transient and steady state; LB-EKF without VR "
        "higher, clearly worse at non-beacon agents; all similar at beacons.\n";
  std::ofstream csv(options.out_dir / "ea2_total_mse.csv");
  csv << "step";
  for (const auto& v : variants) csv << ',' << v.second;
  csv << ",posterior_crb\n";
  for (std::size_t k = 0; k < steps; ++k) {
    csv << k;
    for (const auto& s : sums) csv << ',' << s.total[k] / n;
    csv << ',' << crb_total[k] / n << '\n';
  }
  emit(options.out_dir, "ea2", md.str());
  return 0;
}

// ---------------- 000 E-A3 ----------------
int reproduce_ea3(const ReproduceOptions& options) {
  const std::vector<double> lambdas{0.005, 0.01, 0.02, 0.05, 0.1};
  const std::vector<double> expected_agents{10, 100, 1000, 10000, 100000};
  const int samples = options.trials > 0 ? options.trials : 20;
  const double r = 15.0;
  std::ostringstream md;
  md << "# E-A3 — relabeling bandwidth bound φ_max vs number of agents (000 Fig. 7)\n\n"
     << "r = 15 m; N ~ Poisson(λ l²) in [0, l]²; " << samples << " samples per point; mean ± 2 std of φ_max; "
     << "eq. (35) gives r·sqrt(λ·E|V|). Paper: sublinear growth, slightly above eq. (35).\n\n"
     << "| λ [1/m²] | E|V| | mean |V| | φ_max mean ± 2 std | φ_max / |V| | r·sqrt(λ·E|V|) "
        "|\n|---|---|---|---|---|---|\n";
  std::mt19937_64 rng(options.seed);
  for (double lambda : lambdas) {
    for (double ev : expected_agents) {
      const double side = std::sqrt(ev / lambda);
      double sum = 0.0, sq = 0.0, agents = 0.0;
      for (int s = 0; s < samples; ++s) {
        const auto sample = cen::vr_bandwidth_bound(lambda, side, r, rng);
        sum += sample.phi_max;
        sq += static_cast<double>(sample.phi_max) * sample.phi_max;
        agents += sample.num_agents;
      }
      const double mean = sum / samples;
      const double spread = std::sqrt(std::max(0.0, sq / samples - mean * mean));
      md << "| " << lambda << " | " << ev << " | " << fmt("%.0f", agents / samples) << " | "
         << fmt("%.1f", mean) << " ± " << fmt("%.1f", 2 * spread) << " | "
         << fmt("%.4f", mean / (agents / samples)) << " | " << fmt("%.1f", r * std::sqrt(lambda * ev))
         << " |\n";
    }
  }
  emit(options.out_dir, "ea3", md.str());
  return 0;
}

// ---------------- 001 Tables I and II ----------------
config::Scenario kalman_table_scenario(const std::string& algorithm, int agents, int anchors,
                                       double noise_std_m, std::uint64_t seed) {
  config::Scenario s;  // docs/algorithms.md §3.6 [B-6] defaults
  s.seed = seed;
  s.name = "001-" + algorithm;
  s.algorithm.name = algorithm;
  s.algorithm.process_noise_std_m = 0.01;
  s.algorithm.initial_std_m = 30.0 / std::sqrt(12.0);
  s.world.agents = agents;
  s.world.anchors = anchors;
  s.world.area_m = 30.0;
  s.world.comm_radius_m = 100.0;  // every pair measures
  s.world.initial_guess = config::InitialGuess::kUniform;
  s.noise.range_std_m = noise_std_m;
  s.run.steps = 100;
  return s;
}

}  // namespace

KalmanTableColumn run_kalman_table_column(const std::string& algorithm, int agents, int anchors,
                                          double noise_std_m, int trials, int threads, std::uint64_t seed) {
  const auto scenario = kalman_table_scenario(algorithm, agents, anchors, noise_std_m, seed);
  struct TrialStats {
    double max = 0, min = 0, mean = 0, std = 0, convergence = 0;
    bool failed = false;
  };
  std::vector<TrialStats> stats(static_cast<std::size_t>(trials));
  sim::run_monte_carlo(scenario, trials, threads, {}, [&](int t, const sim::RunRecord& record) {
    const int n = record.agents;
    const auto steps = static_cast<std::int64_t>(record.metrics.size());
    std::vector<bool> anchor(static_cast<std::size_t>(n));
    for (const auto& a : record.agent_summaries) anchor[static_cast<std::size_t>(a.agent)] = a.anchor;
    // Convergence (deviation from [B-8], see docs/reproduction.md): the first step after which the
    // network mean error stays within ±0.5 cm of its final value. [B-8]'s per-node "moves <= 0.5 cm per
    // step" never holds with Q = (0.01 m)²: the steady-state per-step movement is ~0.8 cm.
    std::vector<double> mean_error(static_cast<std::size_t>(steps), 0.0);
    std::vector<double> final_errors;
    for (std::int64_t k = 0; k < steps; ++k) {
      int count = 0;
      for (int i = 0; i < n; ++i) {
        if (anchor[static_cast<std::size_t>(i)]) continue;
        const auto& row = record.estimates[static_cast<std::size_t>(k * n + i)];
        const double error = (row.estimate.mean_m - row.truth).norm();
        mean_error[static_cast<std::size_t>(k)] += error;
        ++count;
        if (k == steps - 1) final_errors.push_back(error);
      }
      mean_error[static_cast<std::size_t>(k)] /= count;
    }
    std::int64_t network_convergence = 0;
    for (std::int64_t k = 0; k < steps; ++k) {
      if (std::abs(mean_error[static_cast<std::size_t>(k)] - mean_error.back()) > 0.005)
        network_convergence = k + 1;
    }
    auto& s = stats[static_cast<std::size_t>(t)];
    const double count = static_cast<double>(final_errors.size());
    s.max = *std::max_element(final_errors.begin(), final_errors.end());
    s.min = *std::min_element(final_errors.begin(), final_errors.end());
    s.mean = std::accumulate(final_errors.begin(), final_errors.end(), 0.0) / count;
    double sq = 0.0;
    for (double e : final_errors) sq += (e - s.mean) * (e - s.mean);
    s.std = std::sqrt(sq / count);
    s.convergence = static_cast<double>(network_convergence);
    s.failed = s.mean > 10.0 * noise_std_m;  // [B-8] failure: mean error above 10x the noise std
  });
  KalmanTableColumn column;
  column.trials = trials;
  int ok = 0;
  for (const auto& s : stats) {
    if (s.failed) continue;
    ++ok;
    column.max_error_cm += 100 * s.max;
    column.min_error_cm += 100 * s.min;
    column.mean_error_cm += 100 * s.mean;
    column.std_error_cm += 100 * s.std;
    column.convergence_step += s.convergence;
  }
  if (ok > 0) {
    column.max_error_cm /= ok, column.min_error_cm /= ok, column.mean_error_cm /= ok,
        column.std_error_cm /= ok;
    column.convergence_step /= ok;
  }
  column.failure_percent = 100.0 * (trials - ok) / trials;
  return column;
}

namespace {

struct PaperColumn {
  std::string label;
  std::string algorithm;
  int agents, anchors;
  double noise;
  double max, min, mean, std, conv, failure;  // paper (std < 0: not reported)
};

int reproduce_kalman_table(const ReproduceOptions& options, const std::string& name,
                           const std::vector<PaperColumn>& columns, const std::string& title) {
  const int trials = options.trials > 0 ? options.trials : 100;
  const auto started = std::chrono::steady_clock::now();
  std::vector<KalmanTableColumn> ours;
  for (const auto& c : columns) {
    ours.push_back(run_kalman_table_column(c.algorithm, c.agents, c.anchors, c.noise, trials, options.threads,
                                           options.seed));
    std::fprintf(stderr, "  %s done\n", c.label.c_str());
  }
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  std::ostringstream md;
  md << "# " << title << "\n\n"
     << trials << " trials per column, seed " << options.seed
     << " (configuration per trial: the scenario seed fixes placement; initial guesses, noise and loss per "
        "trial — "
        "here placement is redrawn per column only). Every pair measures; Q = (0.01 m)² I; initial guesses "
        "uniform "
        "in 30 m × 30 m; IEKF P_0 = (30 m)²/12 I; 100 steps ([B-6]). Statistics over non-anchor nodes at the "
        "final "
        "step, averaged over non-failed trials ([B-8]); failure = final mean error > 10× the noise std; "
        "convergence "
        "step = first step after which the network mean error stays within ±0.5 cm of its final value (see "
        "docs/reproduction.md for why not [B-8]'s per-node rule). Each cell: ours / paper. Wall time "
     << fmt("%.1f", wall_s) << " s.\n\n| |";
  for (const auto& c : columns) md << ' ' << c.label << " |";
  md << "\n|---|";
  for (std::size_t k = 0; k < columns.size(); ++k) md << "---|";
  md << "\n";
  auto row = [&](const char* label, auto ours_value, auto paper_value, const char* format) {
    md << "| " << label << " |";
    for (std::size_t k = 0; k < columns.size(); ++k) {
      const double p = paper_value(columns[k]);
      md << ' ' << fmt(format, ours_value(ours[k])) << " / " << (p < 0 ? std::string("–") : fmt(format, p))
         << " |";
    }
    md << "\n";
  };
  row(
      "Max error [cm]", [](const auto& o) { return o.max_error_cm; }, [](const auto& p) { return p.max; },
      "%.2f");
  row(
      "Min error [cm]", [](const auto& o) { return o.min_error_cm; }, [](const auto& p) { return p.min; },
      "%.2f");
  row(
      "Mean error [cm]", [](const auto& o) { return o.mean_error_cm; }, [](const auto& p) { return p.mean; },
      "%.2f");
  row(
      "Std dev [cm]", [](const auto& o) { return o.std_error_cm; }, [](const auto& p) { return p.std; },
      "%.2f");
  row(
      "Conv. step", [](const auto& o) { return o.convergence_step; }, [](const auto& p) { return p.conv; },
      "%.0f");
  row(
      "% Failure", [](const auto& o) { return o.failure_percent; }, [](const auto& p) { return p.failure; },
      "%.0f");
  md << "| Mean error ratio ours/paper |";
  for (std::size_t k = 0; k < columns.size(); ++k)
    md << ' ' << fmt("%.2f", ours[k].mean_error_cm / columns[k].mean) << " |";
  md << "\n";
  emit(options.out_dir, name, md.str());
  return 0;
}

// ---------------- 002 Figs. 2, 4: distributed Jacobi vs BLUE ----------------
/// The Jacobi experiment once per variant k < count, on the reproduction's threads; `vary(config, k)` turns
/// the base configuration into variant k.
template <typename Vary>
std::vector<sim::experiments::JacobiExperimentResult> run_jacobi_variants(
    const sim::experiments::JacobiExperimentConfig& base, std::size_t count, int threads, Vary vary) {
  std::vector<sim::experiments::JacobiExperimentResult> results(count);
  parallel_trials(static_cast<int>(count), threads, [&](int k) {
    auto variant = base;
    vary(variant, static_cast<std::size_t>(k));
    results[static_cast<std::size_t>(k)] = sim::experiments::run_jacobi_experiment(variant);
  });
  return results;
}

// Both readings of "randomly generated graphs with 300 nodes and 1288 edges" ([C-5]): the spec's random
// geometric default and Erdős–Rényi G(n, m). One table and one CSV per reading.
int reproduce_jacobi(const ReproduceOptions& options) {
  using sim::experiments::RelativeGraphModel;
  std::ostringstream md;
  md << "# 002 Figs. 2 and 4 — distributed Jacobi localization from relative measurements\n\n"
     << "The paper shows RMSE falling toward zero (no numbers); the acceptance asks for monotone decrease "
     << "and, at step 50, RMSE within 1.2× the BLUE/CRB. The source says only \"randomly generated graphs "
     << "with 300 nodes and 1288 edges\" ([C-5]), so both readings are run on the same seed: the spec's "
     << "default (random geometric graph) and Erdős–Rényi G(n, m).\n";
  for (const RelativeGraphModel model : {RelativeGraphModel::kGeometric, RelativeGraphModel::kGnm}) {
    const bool gnm = model == RelativeGraphModel::kGnm;
    sim::experiments::JacobiExperimentConfig config;
    config.runs = options.trials > 0 ? options.trials : 50;
    config.seed = options.seed;
    config.graph_model = model;
    const auto started = std::chrono::steady_clock::now();
    const auto result = sim::experiments::run_jacobi_experiment(config);
    const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    // Same seed, graphs and priors with (near) noise-free measurements: what is left is the decay of the
    // prior error alone, a floor the noisy run cannot beat.
    auto noise_free = config;
    noise_free.measurement_std_m = 1e-6;
    const auto transient = sim::experiments::run_jacobi_experiment(noise_free);
    md << "\n## " << (gnm ? "G(n, m) reading" : "Random geometric graph (docs/algorithms.md §4.6 default)")
       << "\n\n"
       << config.num_nodes << " nodes, exactly " << config.num_edges << " edges ("
       << (gnm ? "pairs drawn uniformly"
               : "random geometric graph, mean radius " + fmt("%.2f", result.mean_radius_m) + " m")
       << ", points uniform in " << config.side_m << " m × " << config.side_m << " m, mean edge length "
       << fmt("%.1f", result.mean_edge_length_m) << " m), priors truth + N(0, " << config.prior_std_m
       << "² I), 𝓔 = (" << config.measurement_std_m << " m)² I, one shared draw per edge and step ([C-7]), "
       << config.runs << " runs, seed " << options.seed << " (" << fmt("%.1f", wall_s) << " s).\n\n"
       << "| step | Jacobi RMSE [m] | BLUE RMSE [m] | CRB [m] | Jacobi / BLUE | prior transient only [m] |\n"
       << "|---|---|---|---|---|---|\n";
    for (std::size_t t = 0; t < result.rmse.size(); ++t) {
      if (t > 5 && t % 5 != 0 && t + 1 != result.rmse.size()) continue;
      md << "| " << t << " | " << fmt("%.4f", result.rmse[t]) << " | " << fmt("%.4f", result.blue_rmse[t])
         << " | " << fmt("%.4f", result.crb_rmse[t]) << " | "
         << fmt("%.2f", result.rmse[t] / result.blue_rmse[t]) << " | " << fmt("%.4f", transient.rmse[t])
         << " |\n";
    }
    bool monotone = true;
    for (std::size_t t = 1; t < result.rmse.size(); ++t)
      monotone = monotone && result.rmse[t] <= result.rmse[t - 1];
    const std::size_t last = result.rmse.size() - 1;
    md << "\nMonotone decrease of the mean RMSE: " << (monotone ? "yes" : "no") << ". At step " << last
       << ": Jacobi / BLUE = " << fmt("%.2f", result.rmse[last] / result.blue_rmse[last])
       << " (acceptance: ≤ 1.2). With noise-free measurements the same runs are still at "
       << fmt("%.3f", transient.rmse[last]) << " m at step " << last << " ("
       << fmt("%.2f", transient.rmse[last] / result.blue_rmse[last])
       << "× the BLUE): the prior errors' common mode decays only through the one reference node.\n";
    // Not in 002: more eq. (9) exchanges between two measurements (agents that talk faster than they
    // measure). What it takes for the transient to drain by step 50 on these graphs.
    md << "\nNot in the source — several eq. (9) sweeps per measurement step (the agents exchange estimates "
          "this many times between two measurements; same seed, graphs, priors and noise):\n\n"
       << "| sweeps per step | RMSE step 10 [m] | / BLUE | RMSE step 50 [m] | / BLUE "
          "|\n|---|---|---|---|---|\n";
    // Largest first, so that the threads finish together (the cost grows with the sweeps).
    const std::vector<int> sweep_counts{50, 30, 20, 10};
    const auto swept =
        run_jacobi_variants(config, sweep_counts.size(), options.threads,
                            [&](auto& variant, std::size_t k) { variant.sweeps_per_step = sweep_counts[k]; });
    for (const int sweeps : {1, 10, 20, 30, 50}) {
      const auto at = std::find(sweep_counts.begin(), sweep_counts.end(), sweeps);
      const auto& r =
          at == sweep_counts.end() ? result : swept[static_cast<std::size_t>(at - sweep_counts.begin())];
      md << "| " << sweeps << " | " << fmt("%.4f", r.rmse[10]) << " | "
         << fmt("%.2f", r.rmse[10] / r.blue_rmse[10]) << " | " << fmt("%.4f", r.rmse[last]) << " | "
         << fmt("%.2f", r.rmse[last] / r.blue_rmse[last]) << " |\n";
    }
    // 𝓔 is not in 002 ([C-5]). The prior transient does not depend on it, the BLUE's error grows with it,
    // so the ratio at step 50 says how noisy the relative measurements must be for one sweep to keep up.
    md << "\nOne sweep per step (002 as printed) with other relative-measurement noise (𝓔 is not given by "
          "002; same seed, graphs and priors):\n\n"
       << "| 𝓔 std [m] | RMSE step 50 [m] | BLUE step 50 [m] | / BLUE |\n|---|---|---|---|\n";
    const std::vector<double> noise_levels{2.0, 3.0, 5.0, 8.0};
    const auto noisier = run_jacobi_variants(
        config, noise_levels.size(), options.threads,
        [&](auto& variant, std::size_t k) { variant.measurement_std_m = noise_levels[k]; });
    for (std::size_t k = 0; k <= noise_levels.size(); ++k) {
      const auto& r = k == 0 ? result : noisier[k - 1];
      const double std_m = k == 0 ? config.measurement_std_m : noise_levels[k - 1];
      md << "| " << fmt("%.0f", std_m) << " | " << fmt("%.4f", r.rmse[last]) << " | "
         << fmt("%.4f", r.blue_rmse[last]) << " | " << fmt("%.2f", r.rmse[last] / r.blue_rmse[last])
         << " |\n";
    }
    std::filesystem::create_directories(options.out_dir);
    std::ofstream csv(options.out_dir / (gnm ? "jacobi_002_gnm.csv" : "jacobi_002.csv"));
    csv << "step,jacobi_rmse_m,blue_rmse_m,crb_rmse_m\n";
    for (std::size_t t = 0; t < result.rmse.size(); ++t) {
      csv << t << ',' << result.rmse[t] << ',' << result.blue_rmse[t] << ',' << result.crb_rmse[t] << '\n';
    }
  }
  emit(options.out_dir, "jacobi_002", md.str());
  return 0;
}

// ---------------- 003 Figs. 2-3: multipath BP vs pairwise ----------------
namespace {

/// |x error| statistics of one 003 run, pooled over the nodes the paper's Fig. 2 claims are about.
struct MultipathSummary {
  double far_bp_below_2m = 0.0;  ///< BP, S3/S4
  double all_bp_below_3m = 0.0;  ///< BP, S1–S4
  std::size_t bp_above_3m = 0;   ///< BP, S1–S4: how many node-trials
  double bp_largest = 0.0;       ///< BP, S1–S4, largest |x error|
  double far_bp_median = 0.0;
  double far_pairwise_median = 0.0;
  double near_pairwise_median = 0.0;
  double all_central_below_3m = 0.0;  ///< centralized WLS, S1–S4
  std::size_t central_above_3m = 0;
};

MultipathSummary summarize_multipath(const sim::experiments::MultipathExperimentResult& r) {
  auto pool = [](const std::vector<std::vector<double>>& per_node, int first, int last) {
    std::vector<double> pooled;
    for (int node = first; node <= last; ++node) {
      const auto& v = per_node[static_cast<std::size_t>(node)];
      pooled.insert(pooled.end(), v.begin(), v.end());
    }
    return pooled;
  };
  auto count_at_least = [](const std::vector<double>& v, double limit) {
    return static_cast<std::size_t>(
        std::count_if(v.begin(), v.end(), [&](double e) { return std::abs(e) >= limit; }));
  };
  auto fraction_below = [&](const std::vector<double>& v, double limit) {
    return v.empty() ? 0.0
                     : 1.0 - static_cast<double>(count_at_least(v, limit)) / static_cast<double>(v.size());
  };
  const auto far_bp = pool(r.bp_x_error, 3, 4);
  const auto all_bp = pool(r.bp_x_error, 1, 4);
  const auto all_central = pool(r.centralized_x_error, 1, 4);
  MultipathSummary summary;
  summary.far_bp_below_2m = fraction_below(far_bp, 2.0);
  summary.all_bp_below_3m = fraction_below(all_bp, 3.0);
  summary.bp_above_3m = count_at_least(all_bp, 3.0);
  summary.bp_largest = sim::experiments::abs_quantile(all_bp, 1.0);
  summary.far_bp_median = sim::experiments::abs_quantile(far_bp, 0.5);
  summary.far_pairwise_median = sim::experiments::abs_quantile(pool(r.pairwise_x_error, 3, 4), 0.5);
  summary.near_pairwise_median = sim::experiments::abs_quantile(pool(r.pairwise_x_error, 1, 2), 0.5);
  summary.all_central_below_3m = fraction_below(all_central, 3.0);
  summary.central_above_3m = count_at_least(all_central, 3.0);
  return summary;
}

}  // namespace

int reproduce_multipath(const ReproduceOptions& options) {
  const int trials = options.trials > 0 ? options.trials : 1000;
  std::ostringstream md;
  md << "# 003 Figs. 2–3 — cooperative multipath BP vs pairwise localization\n\n"
     << "5 nodes in 10 m × 10 m, S_0 anchor at the origin, links S1–S0, S2–S0, S3–S1, S4–S2, S3–S4, one "
        "reflection per wall, walls 5 m beyond the square's circumscribed circle, DOA error U(±5°) at each "
        "end, 50 BP iterations, seed "
     << options.seed
     << ". Paper (Fig. 2): cooperative > 90 % of |x errors| below 2 m and all below 3 m; pairwise S3, S4 "
        "markedly worse than S1, S2.\n\n"
     << "| walls | range noise | trials | BP S3/S4 < 2 m | BP all < 3 m | BP p50 S3/S4 [m] | pairwise p50 "
        "S3/S4 [m] | pairwise p50 S1/S2 [m] | centralized all < 3 m | Thm. 1 violations |\n"
        "|---|---|---|---|---|---|---|---|---|---|\n";
  struct Setup {
    std::vector<double> walls;
    double range_std;
    const char* label;
    bool doa_aware = false;                     // not in 003: paths weighted by their angle errors too
    bool exact_messages = false;                // not in 003: exact GaBP (cavity messages)
    bool lengths_from_measured_angles = false;  // the other reading of how 003 drew its lengths
  };
  const std::vector<Setup> setups{
      {{0.0, 45.0}, 3.0, "0°, 45°"},
      {{0.0, 45.0}, std::sqrt(3.0), "0°, 45°"},
      {{10.0, 20.0, 30.0}, 3.0, "10°, 20°, 30°"},
      {{0.0, 45.0}, 3.0, "0°, 45°, angle-aware (not in 003)", true},
      {{0.0, 45.0}, std::sqrt(3.0), "0°, 45°, angle-aware (not in 003)", true},
      {{10.0, 20.0, 30.0}, 3.0, "10°, 20°, 30°, angle-aware (not in 003)", true},
      {{0.0, 45.0}, 3.0, "0°, 45°, exact GaBP (not in 003)", false, true},
      {{0.0, 45.0}, std::sqrt(3.0), "0°, 45°, exact GaBP (not in 003)", false, true},
      {{0.0, 45.0}, std::sqrt(3.0), "0°, 45°, angle-aware exact GaBP (not in 003)", true, true},
      {{0.0, 45.0}, 3.0, "0°, 45°, lengths from eq. (1) at the measured angles", false, false, true},
      {{0.0, 45.0},
       std::sqrt(3.0),
       "0°, 45°, lengths from eq. (1) at the measured angles",
       false,
       false,
       true}};
  for (const auto& setup : setups) {
    sim::experiments::MultipathExperimentConfig config;
    config.trials = trials;
    config.seed = options.seed;
    config.wall_angles_deg = setup.walls;
    config.range_std_m = setup.range_std;
    config.doa_aware_paths = setup.doa_aware;
    config.exact_messages = setup.exact_messages;
    config.lengths_from_measured_angles = setup.lengths_from_measured_angles;
    const auto r = sim::experiments::run_multipath_experiment(config);
    const auto summary = summarize_multipath(r);
    md << "| " << setup.label << " | std " << fmt("%.2f", setup.range_std) << " m | " << config.trials
       << " | " << fmt("%.1f %%", 100.0 * summary.far_bp_below_2m) << " | "
       << fmt("%.2f %%", 100.0 * summary.all_bp_below_3m) << " | " << fmt("%.2f", summary.far_bp_median)
       << " | " << fmt("%.2f", summary.far_pairwise_median) << " | "
       << fmt("%.2f", summary.near_pairwise_median) << " | "
       << fmt("%.2f %%", 100.0 * summary.all_central_below_3m) << " | " << r.covariance_increase_trials
       << " |\n";
  }
  md << "\n|x error| of nodes S1–S4 after 50 iterations; 'Thm. 1 violations' counts trials in which some "
        "belief's covariance grew between iterations (Thm. 1 is about 003's form; exact GaBP is not covered "
        "by it). The angle-aware rows (not in 003; `algorithm.path_variance=with_doa` in the runtime) give "
        "each path the variance σ² + σ_θ²(‖g‖² − 1)d²/2 of its length and angle errors (σ_θ² = 5²/3 deg²) "
        "instead of σ²; same seed, geometry and noise. The exact GaBP rows (not in 003, the [D-4] ablation; "
        "`algorithm.bp_messages=exact`) divide each node's own contribution out of the belief it receives. "
        "'centralized' is weighted least squares on all five links' paths at once (not in 003), which exact "
        "GaBP's means converge to. Every row but the last two draws a path's length by the image method "
        "(docs/algorithms.md §5.4), so the angle errors also make eq. (1) wrong; the last two read 003's "
        "Sec. 4 "
        "as "
        "drawing each length from eq. (1) itself at the measured angles, g(θ̃_ij, θ̃_ji)ᵀ(s_i − s_j) plus the "
        "range noise — the model its Thm. 2 (unbiased means) takes as exact — so the angle errors enter only "
        "through G. With two walls pairwise is unchanged (two paths, two unknowns).\n";

  // Where the walls stand is not in 003 ([D-6]); the angle errors' effect grows as the rays to a far wall
  // become parallel, so the figure's numbers depend on it.
  md << "\n## Wall distance (not given by 003)\n\n"
     << "Walls 0° and 45°, 003's BP as printed, " << trials
     << " trials per row; the margin is the distance between a wall and the square's circumscribed circle "
        "(0 m: the walls touch it).\n\n"
     << "| margin [m] | range noise | BP S3/S4 < 2 m | BP all < 3 m | BP above 3 m | BP largest [m] | "
        "centralized all < 3 m | centralized above 3 m |\n|---|---|---|---|---|---|---|---|\n";
  for (const double margin : {0.0, 2.0, 5.0, 10.0, 20.0}) {
    for (const double range_std : {3.0, std::sqrt(3.0)}) {
      sim::experiments::MultipathExperimentConfig config;
      config.trials = trials;
      config.seed = options.seed;
      config.range_std_m = range_std;
      config.wall_margin_m = margin;
      const auto summary = summarize_multipath(sim::experiments::run_multipath_experiment(config));
      md << "| " << fmt("%.0f", margin) << " | std " << fmt("%.2f", range_std) << " m | "
         << fmt("%.1f %%", 100.0 * summary.far_bp_below_2m) << " | "
         << fmt("%.2f %%", 100.0 * summary.all_bp_below_3m) << " | " << summary.bp_above_3m << " of "
         << 4 * trials << " | " << fmt("%.2f", summary.bp_largest) << " | "
         << fmt("%.2f %%", 100.0 * summary.all_central_below_3m) << " | " << summary.central_above_3m
         << " |\n";
    }
  }
  // Which error makes the tail, and how the other reading of the lengths changes it; same seed (every
  // draw is made in every row).
  md << "\n## Where the errors above 3 m come from\n\n"
     << "Walls 0° and 45° at the 5 m margin, " << trials
     << " trials per row, 003's BP as printed and the centralized least squares on the same draws. 'image': "
        "lengths by the image method (§5.4); 'eq. (1)': lengths from eq. (1) at the measured angles.\n\n"
     << "| range noise | DOA error | lengths | BP S3/S4 < 2 m | BP all < 3 m | BP above 3 m | BP largest [m] "
        "| "
        "centralized above 3 m |\n|---|---|---|---|---|---|---|---|\n";
  struct Source {
    double doa_deg;
    bool lengths_from_measured_angles;
  };
  for (const double range_std : {3.0, std::sqrt(3.0)}) {
    for (const Source source : {Source{5.0, false}, Source{0.0, false}, Source{5.0, true}}) {
      sim::experiments::MultipathExperimentConfig config;
      config.trials = trials;
      config.seed = options.seed;
      config.range_std_m = range_std;
      config.doa_error_deg = source.doa_deg;
      config.lengths_from_measured_angles = source.lengths_from_measured_angles;
      const auto summary = summarize_multipath(sim::experiments::run_multipath_experiment(config));
      md << "| std " << fmt("%.2f", range_std) << " m | " << (source.doa_deg > 0.0 ? "U(±5°)" : "none")
         << " | " << (source.lengths_from_measured_angles ? "eq. (1)" : "image") << " | "
         << fmt("%.1f %%", 100.0 * summary.far_bp_below_2m) << " | "
         << fmt("%.2f %%", 100.0 * summary.all_bp_below_3m) << " | " << summary.bp_above_3m << " of "
         << 4 * trials << " | " << fmt("%.2f", summary.bp_largest) << " | " << summary.central_above_3m
         << " |\n";
    }
  }
  md << "\nWith exact angles the centralized solution is the efficient estimator of eq. (1), so what remains "
        "above 3 m there is the length noise's own tail; the rest of the tail in the image rows is what the "
        "angle errors do to eq. (1).\n";
  emit(options.out_dir, "multipath_003", md.str());
  return 0;
}

// ---------------- 004 Table I: DG-BB vs baselines ----------------
int reproduce_dgbb_table1(const ReproduceOptions& options) {
  sim::experiments::LatticeConfig config;
  config.runs = options.trials > 0 ? options.trials : 50;
  config.seed = options.seed;
  config.both_diagonals = true;
  estimators::gradient::DgBbParams base;
  base.consensus_rounds = 20;
  base.abs_tol = 1e-10;
  base.max_updates = 100000;
  const auto started = std::chrono::steady_clock::now();
  const auto rows = sim::experiments::run_table_one(config, base);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  // The paper's τ_end and rounds per row (both local BB readings against its one local BB row).
  const std::vector<std::pair<double, double>> paper{{262, 5240}, {6071, 6071}, {23491, 23491},
                                                     {1e5, 1e5},  {1e5, 1e5},   {6071, 6071}};
  std::ostringstream md;
  md << "# 004 Table I — DG-BB and baselines on the 10 × 10 lattice\n\n"
     << "100 nodes on [0, 1]², anchors at the corners, lattice edges plus both diagonals, noiseless ranges, "
        "σ_I = "
     << config.initial_std << ", T = 20, η_abstol = 1e−10, τ_max = 1e5, " << config.runs << " runs, seed "
     << options.seed << " (" << fmt("%.1f", wall_s) << " s).\n\n"
     << "| method | τ_end ours | τ_end paper | rounds ours (source count) | rounds paper | converged | final "
        "Φ | trust-region cuts per run |\n"
     << "|---|---|---|---|---|---|---|---|\n";
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const auto& row = rows[k];
    md << "| " << row.method << " | " << fmt("%.1f", row.mean_tau_end) << " | "
       << (k < paper.size() ? fmt("%.0f", paper[k].first) : std::string("–")) << " | "
       << fmt("%.0f", row.mean_source_rounds) << " | "
       << (k < paper.size() ? fmt("%.0f", paper[k].second) : std::string("–")) << " | "
       << fmt("%.0f %%", 100.0 * row.fraction_converged) << " | "
       << (std::isfinite(row.mean_final_error) ? fmt("%.2e", row.mean_final_error)
                                               : std::string("diverged (NaN/Inf)"))
       << " | " << fmt("%.1f", row.mean_trust_region_fires) << " |\n";
  }
  md << "\nThe two local BB rows without a trust region read eq. (15) two ways. The first, "
        "docs/algorithms.md "
        "[E-6], takes ΔD_i = D_i(p^(τ)) − D_i(p^(τ−1)), the change of node i's gradient with its neighbours' "
        "moves in it. The sixth row takes the equation as printed, ∇_i f(p_i^(τ)) − ∇_i f(p_i^(τ−1)): both "
        "gradients at the neighbours' newest positions, so ΔD_i is what node i's own move changed (node i "
        "has everything it needs after the one exchange per update).\n\n"
     << "The last two rows are not in the source: the same methods with the BB trust region "
        "(`algorithm.max_move_fraction` = 1, the runtime's default: one update moves a node at most its "
        "shortest measured range). The first six rows run without it.\n";
  emit(options.out_dir, "dgbb_004_table1", md.str());
  return 0;
}

// ---------------- 004 Figs. 4–7: convergence and scaling of DG-BB on lattices ----------------
int reproduce_dgbb_figures(const ReproduceOptions& options) {
  const int runs = options.trials > 0 ? options.trials : 50;  // 004: 50 runs (Fig. 4; the others unstated)
  estimators::gradient::DgBbParams base;
  base.consensus_rounds = 20;
  base.abs_tol = 1e-10;
  base.max_updates = 100000;
  sim::experiments::ConvergenceFiguresConfig convergence;
  convergence.lattice.side = 10;
  convergence.lattice.both_diagonals = true;
  convergence.lattice.runs = runs;
  convergence.lattice.seed = options.seed;
  convergence.threads = resolve_threads(options.threads);
  sim::experiments::ScalingFiguresConfig scaling;
  scaling.lattice = convergence.lattice;
  scaling.threads = convergence.threads;
  const auto started = std::chrono::steady_clock::now();
  const auto figures = sim::experiments::run_convergence_figures(convergence, base);
  const double convergence_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  const auto cells = sim::experiments::run_scaling_figures(scaling, base);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();

  std::ostringstream md;
  md << "# 004 Figs. 4–7 — DG-BB on anchored lattices: convergence and scaling\n\n"
     << "Lattices of Table I ([0, 1]², anchors at the corners, lattice edges plus both diagonals, noiseless "
        "ranges), τ_max = 1e5, no trust region; η_abstol = 1e−10 as in Table I, and 1e−14 in a second "
        "table for Figs. 5–7 (see the end); "
     << runs << " runs per cell, seed " << options.seed << ", " << convergence.threads << " threads ("
     << fmt("%.0f", convergence_s) << " s for Figs. 4–5, " << fmt("%.0f", wall_s - convergence_s)
     << " s for Figs. 6–7). Local BB is eq. (15) as printed (docs/algorithms.md [E-6]'s reading diverges on "
        "this "
        "lattice, Table I). 004 gives these figures as curves without numbers; its claims are quoted above "
        "each table.\n\n"
     << "## Fig. 4 — Φ against τ, n = 100, σ_I = " << convergence.traced_initial_std << "\n\n"
     << "004: DG-BB converges fastest; local steps cause spikes; the fixed step has long tails. Mean Φ over "
        "the runs after update τ (a run that stopped keeps its final Φ); spikes: updates per run at which Φ "
        "grew by more than 10 %.\n\n| method |";
  for (const auto tau : convergence.trace_taus) md << " τ = " << tau << " |";
  md << " spikes per run |\n|---|";
  for (std::size_t k = 0; k <= convergence.trace_taus.size(); ++k) md << "---|";
  md << "\n";
  for (const auto& curve : figures.curves) {
    md << "| " << curve.method << " |";
    for (const double phi : curve.mean_error) md << " " << fmt("%.2e", phi) << " |";
    md << " " << fmt("%.1f", curve.spikes_per_run) << " |\n";
  }
  for (const double abs_tol : convergence.abs_tols) {
    md << "\n## Fig. 5 — convergent runs against σ_I, n = 100, η_abstol = " << fmt("%.0e", abs_tol) << "\n\n"
       << "004: DG-BB has the highest share of convergent runs. Converged: Φ < 1e−3 before τ_max ([E-9]); "
          "mean τ_end in brackets.\n\n| method |";
    for (const double s : convergence.initial_stds) md << " σ_I = " << s << " |";
    md << "\n|---|";
    for (std::size_t k = 0; k < convergence.initial_stds.size(); ++k) md << "---|";
    md << "\n";
    for (const auto& curve : figures.curves) {
      md << "| " << curve.method << " |";
      for (const auto& c : figures.cells) {
        if (c.method != curve.method || c.abs_tol != abs_tol) continue;
        md << " " << fmt("%.0f %%", 100.0 * c.fraction_converged) << " (" << fmt("%.0f", c.mean_tau_end)
           << ") |";
      }
      md << "\n";
    }
  }
  // Figs. 6–7, one table pair per stopping tolerance.
  auto tau = [](double value) { return std::isfinite(value) ? fmt("%.0f", value) : std::string("–"); };
  for (const double abs_tol : scaling.abs_tols) {
    md << "\n## Fig. 6 — τ_end against T, DG-BB, η_abstol = " << fmt("%.0e", abs_tol) << "\n\n"
       << "004: even a small T cuts τ_end strongly, and a large T is not needed. σ_I = "
       << scaling.initial_std_per_spacing
       << " lattice spacings (Table I's 0.05 at n = 100; 004 does not say how σ_I scales with n). Mean τ_end "
          "of the convergent runs [share of convergent runs]. Local BB (T = 0) at n = 100: Fig. 5's σ_I = "
          "0.05 column.\n\n| n |";
    for (const int t : scaling.consensus_rounds) md << " T = " << t << " |";
    md << "\n|---|";
    for (std::size_t k = 0; k < scaling.consensus_rounds.size(); ++k) md << "---|";
    md << "\n";
    for (const int side : scaling.sides) {
      md << "| " << side * side << " |";
      for (const int t : scaling.consensus_rounds) {
        for (const auto& c : cells) {
          if (c.abs_tol != abs_tol || c.nodes != side * side || c.consensus_rounds != t) continue;
          md << " " << tau(c.mean_tau_end_converged) << " [" << fmt("%.0f %%", 100.0 * c.fraction_converged)
             << "] |";
          break;
        }
      }
      md << "\n";
    }
    md << "\n## Fig. 7 — τ_end against n, DG-BB, T = 20, η_abstol = " << fmt("%.0e", abs_tol) << "\n\n"
       << "004: τ_end grows mildly with n.\n\n| n | mean τ_end, convergent runs | mean τ_end, all runs | "
          "converged | mean final Φ |\n|---|---|---|---|---|\n";
    std::vector<int> listed;
    for (const auto& c : cells) {
      if (c.abs_tol != abs_tol || c.consensus_rounds != 20) continue;
      if (std::find(listed.begin(), listed.end(), c.nodes) != listed.end()) continue;
      listed.push_back(c.nodes);
      md << "| " << c.nodes << " | " << tau(c.mean_tau_end_converged) << " | " << fmt("%.0f", c.mean_tau_end)
         << " | " << fmt("%.0f %%", 100.0 * c.fraction_converged) << " | " << fmt("%.1e", c.mean_final_error)
         << " |\n";
    }
  }
  md << "\nWith η_abstol = 1e−10 (Table I's) some runs stop before Φ < 1e−3: runs on the larger "
        "lattices, "
        "and at n = 100 some with a small σ_I, for all three methods alike (compare the two Fig. 5 tables). "
        "Φ then sits on a plateau of a few 1e−3 where the cost is nearly flat (a soft bending mode that "
        "only the four corner anchors hold): each node's move per update falls below η, and the nodes stop "
        "one by one, for good ([E-5]), while their BB steps are of normal size. With η_abstol = 1e−14 the "
        "same "
        "runs get through the plateau (docs/reproduction.md).\n";
  emit(options.out_dir, "dgbb_004_figs", md.str());
  std::ofstream csv(options.out_dir / "dgbb_004_figs.csv");
  csv << "figure,method,nodes,initial_std,consensus_rounds,abs_tol,tau,value,converged\n";
  for (const auto& curve : figures.curves) {
    for (std::size_t k = 0; k < curve.mean_error.size(); ++k) {
      csv << "4," << curve.method << ",100," << convergence.traced_initial_std << ",,"
          << convergence.abs_tols[0] << "," << convergence.trace_taus[k] << "," << curve.mean_error[k]
          << ",\n";
    }
  }
  for (const auto& c : figures.cells) {
    csv << "5," << c.method << ",100," << c.initial_std << ",," << c.abs_tol << ",," << c.mean_tau_end << ","
        << c.fraction_converged << "\n";
  }
  for (const auto& c : cells) {
    csv << "6,"
        << "DG-BB," << c.nodes << "," << c.initial_std << "," << c.consensus_rounds << "," << c.abs_tol
        << ",," << c.mean_tau_end << "," << c.fraction_converged << "\n";
  }
  return 0;
}

// ---------------- 004 Tables II–III: SDP and SDP + DG-BB on random geometric graphs ----------------
std::string phi(double value) { return std::isfinite(value) ? fmt("%.3f", value) : std::string("–"); }

/// Runs, seed and threads of an Example 3 table from the command line (30 runs by default, [E-8]).
template <typename Config>
Config example3_config(const ReproduceOptions& options) {
  Config config;
  config.runs = options.trials > 0 ? options.trials : 30;
  config.seed = options.seed;
  config.threads = resolve_threads(options.threads);
  return config;
}

int reproduce_dgbb_table2(const ReproduceOptions& options) {
  const auto config = example3_config<sim::experiments::TableTwoConfig>(options);
  const auto params = sim::experiments::example3_dgbb_params();
  const auto started = std::chrono::steady_clock::now();
  const auto cells = sim::experiments::run_table_two(config, params);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  // 004 Table II, rows n_a = 20, 10, 3; columns ν_d = 0.05, 0.1, 0.15.
  const std::map<int, std::pair<std::vector<double>, std::vector<double>>> paper{
      {20, {{0.010, 0.017, 0.023}, {0.006, 0.013, 0.018}}},
      {10, {{0.020, 0.033, 0.040}, {0.013, 0.023, 0.032}}},
      {3, {{0.094, 0.145, 0.170}, {0.046, 0.127, 0.156}}}};
  auto cell_of = [&](int anchors, double noise) -> const sim::experiments::TableTwoCell& {
    for (const auto& c : cells) {
      if (c.anchors == anchors && c.noise_factor == noise) return c;
    }
    throw std::logic_error("table2: missing cell");
  };
  std::ostringstream md;
  md << "# 004 Table II — Φ of SDP and SDP + DG-BB on random geometric graphs\n\n"
     << "n = " << config.nodes << " nodes uniform on [0, 1]², R = " << config.radius
     << ", n_a anchors at random, ranges d̄ = |d + ε|, ε ~ N(0, (ν_d d)²) (eq. (16)); graphs resampled until "
        "connected with ≥ 3 ranges per unknown node. SDP: full relaxation (docs/algorithms.md §6.5 item 4, "
        "SDPA). "
        "DG: DG-BB agents from the SDP output, T = 20, η_abstol = 1e−15, τ_max = 1e5. Φ = (1/n) Σ ‖p_i − "
        "p̂_i‖ "
        "over all n nodes (anchors 0, [E-9]). "
     << config.runs << " runs per cell (the same positions, anchor order and noise draws in every cell of a "
     << "run), seed " << options.seed << " (" << fmt("%.1f", wall_s) << " s).\n\n"
     << "| n_a | method | ν_d = 0.05 ours | paper | ν_d = 0.1 ours | paper | ν_d = 0.15 ours | paper |\n"
     << "|---|---|---|---|---|---|---|---|\n";
  bool all_improved = true;
  for (const int anchors : config.anchors) {
    const auto& ref =
        paper.count(anchors) ? paper.at(anchors) : std::pair<std::vector<double>, std::vector<double>>{};
    for (int method = 0; method < 2; ++method) {
      md << "| " << anchors << " | " << (method == 0 ? "SDP" : "SDP+DG") << " |";
      for (std::size_t k = 0; k < config.noise_factors.size(); ++k) {
        const auto& c = cell_of(anchors, config.noise_factors[k]);
        const double ours = method == 0 ? c.sdp_error : c.refined_error;
        const auto& column = method == 0 ? ref.first : ref.second;
        md << ' ' << phi(c.runs > 0 ? ours : std::numeric_limits<double>::quiet_NaN()) << " | "
           << (k < column.size() ? fmt("%.3f", column[k]) : "–") << " |";
        if (method == 1 && !(c.refined_error < c.sdp_error)) all_improved = false;
      }
      md << "\n";
    }
  }
  md << "\nSDP+DG improves on SDP in every column: **" << (all_improved ? "yes" : "no") << "**.\n\n"
     << "| n_a | ν_d | runs used | SDP failed | SDP inaccurate (gap > 1e−5) | runs where SDP+DG < SDP | mean "
        "τ_end | median τ_end | "
        "τ_max "
        "reached |\n|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& c : cells) {
    md << "| " << c.anchors << " | " << c.noise_factor << " | " << c.runs << " | " << c.sdp_failures << " | "
       << c.sdp_inaccurate << " | " << c.refined_better << " / " << c.runs << " | "
       << fmt("%.0f", c.mean_tau_end) << " | " << fmt("%.0f", c.median_tau_end) << " | " << c.tau_max_reached
       << " |\n";
  }
  emit(options.out_dir, "dgbb_004_table2", md.str());
  std::ofstream csv(options.out_dir / "dgbb_004_table2.csv");
  csv << "anchors,noise_factor,runs,sdp_failures,phi_sdp,phi_sdp_dg,refined_better,mean_tau_end,median_tau_"
         "end,"
         "tau_max_reached\n";
  for (const auto& c : cells) {
    csv << c.anchors << ',' << c.noise_factor << ',' << c.runs << ',' << c.sdp_failures << ',' << c.sdp_error
        << ',' << c.refined_error << ',' << c.refined_better << ',' << c.mean_tau_end << ','
        << c.median_tau_end << ',' << c.tau_max_reached << '\n';
  }
  return 0;
}

int reproduce_dgbb_table3(const ReproduceOptions& options) {
  const auto config = example3_config<sim::experiments::TableThreeConfig>(options);
  const auto params = sim::experiments::example3_dgbb_params();
  const auto started = std::chrono::steady_clock::now();
  const auto columns = sim::experiments::run_table_three(config, params);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  // 004 Table III, Δt_max = 10, 20, 30, 50, 100.
  const std::map<std::int64_t, std::array<double, 3>> paper{{10, {0.096, 0.053, 1681}},
                                                            {20, {0.095, 0.053, 1915}},
                                                            {30, {0.099, 0.055, 1859}},
                                                            {50, {0.097, 0.060, 1787}},
                                                            {100, {0.094, 0.063, 1882}}};
  std::ostringstream md;
  md << "# 004 Table III — asynchronous start, SDP + DG-BB\n\n"
     << "n = " << config.nodes << ", R = " << config.radius << ", " << config.anchors
     << " anchors, ν_d = " << config.noise_factor << ", T = 20, η_abstol = 1e−15, τ_max = 1e5, "
     << config.runs << " runs, seed " << options.seed << " (" << fmt("%.1f", wall_s)
     << " s). Node i starts at t_i ~ U{0, …, Δt_max} ticks (one tick = one communication round, [E-7]); "
        "before that it neither steps nor publishes, after it runs on its own T + 1 rounds per update; a "
        "node "
        "waits until every range neighbour has published (§6.4). The same worlds and SDP solutions in every "
        "column; Δt_max = 0 is the synchronous start. τ_end ours = the largest update count of any node, "
        "averaged over runs (median in brackets; a run that stops only at τ_max adds 1e5/runs to the mean); "
        "per node = updates per non-anchor node.\n\n"
     << "| Δt_max | Φ SDP ours | paper | Φ SDP+DG ours | paper | τ_end ours | per node | paper | Φ / Φ_sync "
        "| "
        "τ_max reached |\n|---|---|---|---|---|---|---|---|---|---|\n";
  const double sync = columns.front().refined_error;
  for (const auto& c : columns) {
    const bool has = paper.count(c.max_skew) > 0;
    md << "| " << (c.max_skew == 0 ? std::string("0 (sync)") : std::to_string(c.max_skew)) << " | "
       << phi(c.sdp_error) << " | " << (has ? fmt("%.3f", paper.at(c.max_skew)[0]) : "–") << " | "
       << phi(c.refined_error) << " | " << (has ? fmt("%.3f", paper.at(c.max_skew)[1]) : "–") << " | "
       << fmt("%.0f", c.mean_tau_end) << " (" << fmt("%.0f", c.median_tau_end) << ") | "
       << fmt("%.0f", c.mean_node_updates) << " | " << (has ? fmt("%.0f", paper.at(c.max_skew)[2]) : "–")
       << " | " << fmt("%.2f", c.refined_error / sync) << " | " << c.tau_max_reached << " |\n";
  }
  if (columns.front().sdp_failures > 0)
    md << "\n" << columns.front().sdp_failures << " runs left out: SDP not usable.\n";
  emit(options.out_dir, "dgbb_004_table3", md.str());
  std::ofstream csv(options.out_dir / "dgbb_004_table3.csv");
  csv << "max_skew,runs,phi_sdp,phi_sdp_dg,mean_tau_end,median_tau_end,mean_node_updates,tau_max_reached\n";
  for (const auto& c : columns) {
    csv << c.max_skew << ',' << c.runs << ',' << c.sdp_error << ',' << c.refined_error << ','
        << c.mean_tau_end << ',' << c.median_tau_end << ',' << c.mean_node_updates << ',' << c.tau_max_reached
        << '\n';
  }
  return 0;
}

// ---------------- 002 Figs. 1, 3 ----------------
int reproduce_tracking(const ReproduceOptions& options) {
  sim::experiments::TrackingExperimentConfig config;
  config.runs = options.trials > 0 ? options.trials : 50;
  config.seed = options.seed;
  const auto started = std::chrono::steady_clock::now();
  const auto r = sim::experiments::run_tracking_experiment(config);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  std::ostringstream md;
  md << "# 002 Figs. 1, 3 — distributed tracking of moving targets (DLE, range and bearing)\n\n"
     << "The paper shows curves only: errors grow with time as the targets move away, and node 1's errors "
        "are "
     << "the lowest. Settings (docs/algorithms.md §4.6 defaults where the source is silent): "
     << config.num_sensors << " sensors, node 1 (index 0) at the origin and the others uniform in "
     << config.side_m << " m × " << config.side_m << " m, communication disk " << config.radius_m
     << " m (redrawn until connected); " << config.num_targets
     << " targets, double integrator with τ = " << config.dt_s << " s and q = " << config.q
     << ", starting at N(0, " << config.start_std_m << "² I) with speed " << config.speed_mps
     << " m/s into the square; range std " << config.range_std_m << " m + " << config.range_std_per_m
     << " · distance, bearing std " << config.bearing_std_rad << " rad + " << config.bearing_std_per_m
     << " rad/m · distance; one DLE per target and sensor (known data association), Metropolis weights, "
     << "range–bearing linearized at each sensor's prediction; baseline: a centralized EKF on every reading. "
     << config.runs << " runs, seed " << options.seed << " (" << fmt("%.1f", wall_s) << " s). RMSE over runs "
     << "and targets; 'others' is the RMS over sensors 2…" << config.num_sensors << ".\n\n"
     << "| step | position: node 1 [m] | position: others [m] | position: centralized [m] | velocity: node 1 "
        "[m/s] | velocity: others [m/s] | velocity: centralized [m/s] |\n|---|---|---|---|---|---|---|\n";
  std::filesystem::create_directories(options.out_dir);
  std::ofstream csv(options.out_dir / "tracking_002.csv");
  csv << "step,node1_position_rmse_m,others_position_rmse_m,centralized_position_rmse_m,node1_velocity_rmse_"
         "mps,"
         "others_velocity_rmse_mps,centralized_velocity_rmse_mps\n";
  const std::size_t last = r.others_position_rmse.size() - 1;
  for (std::size_t t = 1; t <= last; ++t) {
    csv << t << ',' << r.node0_position_rmse[t] << ',' << r.others_position_rmse[t] << ','
        << r.centralized_position_rmse[t] << ',' << r.node0_velocity_rmse[t] << ','
        << r.others_velocity_rmse[t] << ',' << r.centralized_velocity_rmse[t] << '\n';
    if (t != 1 && t != 2 && t != 5 && t % 10 != 0 && t != last) continue;
    md << "| " << t << " | " << fmt("%.3f", r.node0_position_rmse[t]) << " | "
       << fmt("%.3f", r.others_position_rmse[t]) << " | " << fmt("%.3f", r.centralized_position_rmse[t])
       << " | " << fmt("%.3f", r.node0_velocity_rmse[t]) << " | " << fmt("%.3f", r.others_velocity_rmse[t])
       << " | " << fmt("%.3f", r.centralized_velocity_rmse[t]) << " |\n";
  }
  emit(options.out_dir, "tracking_002", md.str());
  return 0;
}

// ---------------- 002 Fig. 5 ----------------
int reproduce_joint_field(const ReproduceOptions& options) {
  using estimators::consensus::FieldSensing;
  using sim::experiments::SensorPlacement;
  struct Variant {
    const char* label;
    const char* csv_name;
    FieldSensing sensing;
    SensorPlacement placement;
  };
  const std::array<Variant, 2> variants{{
      {"continuous model, sensors uniform (Fig. 5, middle plots)", "continuous", FieldSensing::kContinuous,
       SensorPlacement::kUniform},
      {"cell-based (discontinuous) model, sensors on cell boundaries (Fig. 5, right)", "boundaries",
       FieldSensing::kCellBased, SensorPlacement::kCellBoundaries},
  }};
  std::array<sim::experiments::JointFieldExperimentResult, variants.size()> results;
  std::array<double, variants.size()> wall_s{};
  sim::experiments::JointFieldExperimentConfig config;
  config.runs = options.trials > 0 ? options.trials : 50;
  config.seed = options.seed;
  config.threads = resolve_threads(options.threads);
  for (std::size_t v = 0; v < variants.size(); ++v) {
    auto variant_config = config;
    variant_config.sensing = variants[v].sensing;
    variant_config.placement = variants[v].placement;
    const auto started = std::chrono::steady_clock::now();
    results[v] = sim::experiments::run_joint_field_experiment(variant_config);
    wall_s[v] = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  }
  std::ostringstream md;
  md << "# 002 Fig. 5 — joint localization and field estimation (eq. (10))\n\n"
     << "The paper shows curves only: location and field RMSE both fall with a continuous observation model, "
     << "and the field RMSE does not vanish when sensors sit on the cell boundaries of a model defined by "
        "the "
     << "cells around the sensor. Settings the source leaves open are docs/algorithms.md §4.6's defaults and "
     << "ours: " << config.num_nodes << " sensors, exactly " << config.num_edges
     << " edges (random geometric graph), a " << config.cells_per_side << " × " << config.cells_per_side
     << " grid over " << config.side_m << " m × " << config.side_m
     << " m, h_k(x) = max(0, 1 − ‖x − c_k‖ / r_s) with r_s = " << config.sensing_radius_m
     << " m; in the cell-based model a sensor reads the cell that contains it (h = e_cell(x)), which jumps "
        "at "
     << "cell boundaries. Field: "
     << "zero mean, std " << config.field_std << ", squared-exponential correlation length "
     << config.field_correlation_m << " m; readings std " << config.observation_std
     << "; priors truth + N(0, " << config.prior_std_m << "² I); 𝓔 = (" << config.measurement_std_m
     << " m)² I, one shared draw per edge "
     << "and step; δ = " << config.delta << "; Metropolis weights; node 0 is the reference. " << config.runs
     << " runs per variant, seed " << options.seed << ". Baselines (§4.6): the same DLE with the true sensor "
     << "positions, and a centralized information filter (true positions, all readings).\n";
  std::filesystem::create_directories(options.out_dir);
  std::ofstream csv(options.out_dir / "joint_field_002.csv");
  csv << "variant,step,location_rmse_m,field_rmse,known_position_field_rmse,centralized_field_rmse\n";
  for (std::size_t v = 0; v < variants.size(); ++v) {
    const auto& r = results[v];
    const std::size_t last = r.field_rmse.size() - 1;
    md << "\n## " << variants[v].label << "\n\n"
       << "Mean radius " << fmt("%.2f", r.mean_radius_m) << " m (" << fmt("%.1f", wall_s[v]) << " s).\n\n"
       << "| step | location RMSE [m] | field RMSE (joint) | field RMSE (true positions) | field RMSE "
       << "(centralized) |\n|---|---|---|---|---|\n";
    for (std::size_t t = 0; t <= last; ++t) {
      csv << variants[v].csv_name << ',' << t << ',' << r.location_rmse[t] << ',' << r.field_rmse[t] << ','
          << r.known_position_field_rmse[t] << ',' << r.centralized_field_rmse[t] << '\n';
      if (t != 0 && t != 1 && t != 2 && t != 5 && t % 10 != 0 && t != last) continue;
      md << "| " << t << " | " << fmt("%.4f", r.location_rmse[t]) << " | " << fmt("%.4f", r.field_rmse[t])
         << " | " << fmt("%.4f", r.known_position_field_rmse[t]) << " | "
         << fmt("%.4f", r.centralized_field_rmse[t]) << " |\n";
    }
    const std::size_t mid = last / 2;
    md << "\nField RMSE: step 10 → " << mid << " → " << last << ": " << fmt("%.4f", r.field_rmse[10]) << " → "
       << fmt("%.4f", r.field_rmse[mid]) << " → " << fmt("%.4f", r.field_rmse[last]) << " (step " << last
       << " / step " << mid << " = " << fmt("%.2f", r.field_rmse[last] / r.field_rmse[mid])
       << "; with true positions "
       << fmt("%.2f", r.known_position_field_rmse[last] / r.known_position_field_rmse[mid]) << ").\n";
  }
  emit(options.out_dir, "joint_field_002", md.str());
  return 0;
}

}  // namespace

const std::vector<std::string>& known_experiments() {
  static const std::vector<std::string> names{"ea1",
                                              "ea2",
                                              "ea3",
                                              "ieif-table1",
                                              "ieif-table2",
                                              "jacobi-002",
                                              "joint-field-002",
                                              "tracking-002",
                                              "multipath-003",
                                              "dgbb-004-table1",
                                              "dgbb-004-figs",
                                              "dgbb-004-table2",
                                              "dgbb-004-table3"};
  return names;
}

int run_reproduce(const ReproduceOptions& options) {
  const auto& e = options.experiment;
  if (e == "ea1") return reproduce_ea1(options);
  if (e == "ea2") return reproduce_ea2(options);
  if (e == "ea3") return reproduce_ea3(options);
  if (e == "jacobi-002") return reproduce_jacobi(options);
  if (e == "joint-field-002") return reproduce_joint_field(options);
  if (e == "tracking-002") return reproduce_tracking(options);
  if (e == "multipath-003") return reproduce_multipath(options);
  if (e == "dgbb-004-table1") return reproduce_dgbb_table1(options);
  if (e == "dgbb-004-figs") return reproduce_dgbb_figures(options);
  if (e == "dgbb-004-table2") return reproduce_dgbb_table2(options);
  if (e == "dgbb-004-table3") return reproduce_dgbb_table3(options);
  if (e == "ieif-table1") {
    return reproduce_kalman_table(
        options, "ieif_table1",
        {{"0.05 m IEIF", "ieif", 90, 30, 0.05, 2.88, 0.14, 1.09, 0.60, 21, 3},
         {"0.05 m IEKF", "iekf", 90, 30, 0.05, 1.79, 0.06, 0.57, 0.36, 39, 10},
         {"0.2 m IEIF", "ieif", 90, 30, 0.2, 11.64, 0.56, 4.38, 2.40, 21, 4},
         {"0.2 m IEKF", "iekf", 90, 30, 0.2, 6.97, 0.24, 2.30, 1.44, 42, 3},
         {"0.5 m IEIF", "ieif", 90, 30, 0.5, 28.52, 1.47, 11.09, 6.00, 25, 4},
         {"0.5 m IEKF", "iekf", 90, 30, 0.5, 18.12, 0.62, 5.92, 3.77, 45, 4}},
        "001 Table I — IEIF vs IEKF, 90 nodes, 30 anchors, noise std 0.05 / 0.2 / 0.5 m");
  }
  if (e == "ieif-table2") {
    return reproduce_kalman_table(
        options, "ieif_table2",
        {{"N120/A30 IEIF", "ieif", 120, 30, 0.1, 5.59, 0.27, 2.17, -1, 20, 4},
         {"N120/A30 IEKF", "iekf", 120, 30, 0.1, 3.53, 0.11, 1.16, -1, 45, 6},
         {"N180/A45 IEIF", "ieif", 180, 45, 0.1, 4.23, 0.13, 1.52, -1, 17, 1},
         {"N180/A45 IEKF", "iekf", 180, 45, 0.1, 3.18, 0.07, 0.96, -1, 31, 0},
         {"N360/A90 IEIF", "ieif", 360, 90, 0.1, 4.11, 0.11, 1.30, -1, 15, 0},
         {"N360/A90 IEKF", "iekf", 360, 90, 0.1, 3.01, 0.05, 0.80, -1, 27, 0}},
        "001 Table II — IEIF vs IEKF, noise std 0.1 m, node/anchor ratio 4, 30 m × 30 m");
  }
  std::string known;
  for (const auto& name : known_experiments()) known += (known.empty() ? "" : ", ") + name;
  std::fprintf(stderr, "error: unknown experiment '%s' (known: %s)\n", e.c_str(), known.c_str());
  return 2;
}

}  // namespace swarmloc::orchestrator
