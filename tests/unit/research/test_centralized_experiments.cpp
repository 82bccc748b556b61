// E-A1 and E-A2 of Khan et al. Sec. 5 (docs/algorithms.md §2.8), reduced in size.
#include <gtest/gtest.h>

#include <iostream>
#include <numeric>
#include <random>

#include "swarmloc/research/centralized_experiments.hpp"

namespace swarmloc::research {
namespace {

// E-A1 (Fig. 2): the error falls steeply until L reaches the bandwidth of A, then slowly, to 0 at n − 1.
TEST(CentralizedExperiments, BandedInversionErrorFallsWithBandwidth) {
  std::mt19937_64 rng(1);
  const int n = 120;
  const int a_bandwidth = 5;
  const auto errors = banded_inversion_errors(n, a_bandwidth, {0, 2, 5, 10, 20, n - 1}, rng);
  for (std::size_t i = 1; i < errors.size(); ++i) EXPECT_LT(errors[i], errors[i - 1]);
  EXPECT_LT(errors[2], 0.1 * errors[0]);
  EXPECT_LT(errors[5], 1e-10);
  std::mt19937_64 same(1);
  EXPECT_NEAR(
      banded_inversion_error(n, a_bandwidth, 5, same, centralized::BandInversionMethod::kSlidingCholesky),
      errors[2], 1e-9);
}

// Mean of MSE_i(k) over trials, steps [from, to) and the given agents.
double mean_mse(const std::vector<Ea2TrialResult>& trials, int from, int to, const std::vector<int>& agents) {
  double sum = 0.0;
  int count = 0;
  for (const auto& t : trials) {
    for (int k = from; k < to; ++k) {
      for (int a : agents) {
        sum += t.agent_mse(k, a);
        ++count;
      }
    }
  }
  return sum / count;
}

// E-A2 (Figs. 5–6) with 20 trials instead of 5000.
TEST(CentralizedExperiments, LbEkfWithRelabelingTracksTheEkf) {
  const Ea2Config config;
  const Ea2World world = make_ea2_world(config);
  EXPECT_LE(world.vr_bandwidth, 10);

  const int trials = 20;
  std::vector<Ea2TrialResult> ekf, lb_vr, lb_no_vr;
  for (int t = 0; t < trials; ++t) {
    const auto seed = static_cast<std::uint64_t>(1000 + t);
    ekf.push_back(run_ea2_trial(config, world, Ea2Variant::kEkf, seed));
    lb_vr.push_back(run_ea2_trial(config, world, Ea2Variant::kLbEkfVr, seed));
    lb_no_vr.push_back(run_ea2_trial(config, world, Ea2Variant::kLbEkfNoVr, seed));
  }
  std::vector<int> all(static_cast<std::size_t>(config.num_agents));
  std::iota(all.begin(), all.end(), 0);
  std::vector<int> non_beacons;
  for (int a : all) {
    if (std::find(world.beacons.begin(), world.beacons.end(), a) == world.beacons.end())
      non_beacons.push_back(a);
  }
  // Steady state: the second half of the horizon. Transient: the first 20 steps, where the cost of
  // an arbitrary labeling is clear; at steady state it is within the Monte Carlo noise of 20 trials
  // (200 trials: +3 % at non-beacons), because the EKF here is limited by linearization error
  // (σ_r = 10 m²), not by information.
  const int from = config.steps / 2;
  const int transient = 20;
  const double n_agents = static_cast<double>(all.size());
  const double ekf_total = mean_mse(ekf, from, config.steps, all) * n_agents;
  const double vr_total = mean_mse(lb_vr, from, config.steps, all) * n_agents;
  const double no_vr_total = mean_mse(lb_no_vr, from, config.steps, all) * n_agents;
  const double ekf_nb = mean_mse(ekf, 0, transient, non_beacons);
  const double vr_nb = mean_mse(lb_vr, 0, transient, non_beacons);
  const double no_vr_nb = mean_mse(lb_no_vr, 0, transient, non_beacons);
  double crb_total = 0.0;
  for (const auto& t : ekf) {
    for (int k = from; k < config.steps; ++k) crb_total += t.crb_total[static_cast<std::size_t>(k)];
  }
  crb_total /= trials * (config.steps - from);
  std::cout << "E-A2: beta natural " << world.natural_bandwidth << ", beta VR(x(0)) " << world.vr_bandwidth
            << ", beta VR(x^(0)) trial0 " << lb_vr[0].labels_bandwidth << ", max Bandwidth(S) VR "
            << lb_vr[0].max_measurement_bandwidth << ", truncated steps VR " << lb_vr[0].truncated_steps
            << ", no-VR " << lb_no_vr[0].truncated_steps << "\n"
            << "E-A2 steady-state total MSE: EKF " << ekf_total << ", LB-EKF+VR " << vr_total << " (ratio "
            << vr_total / ekf_total << "), LB-EKF no VR " << no_vr_total << " (ratio "
            << no_vr_total / ekf_total << "), PCRB " << crb_total << "\n"
            << "E-A2 transient non-beacon mean MSE: EKF " << ekf_nb << ", LB-EKF+VR " << vr_nb
            << ", LB-EKF no VR " << no_vr_nb << std::endl;
  EXPECT_LT(std::abs(vr_total / ekf_total - 1.0), 0.15);
  EXPECT_GT(no_vr_nb, ekf_nb);
  EXPECT_GT(no_vr_nb, vr_nb);
  EXPECT_GT(ekf_total, crb_total);
}

TEST(CentralizedExperiments, VariantsShareTheTrialDraws) {
  Ea2Config config;
  config.steps = 3;
  config.bandwidth = 2 * config.num_agents - 1;
  const Ea2World world = make_ea2_world(config);
  const auto ekf = run_ea2_trial(config, world, Ea2Variant::kEkf, 7);
  const auto lb = run_ea2_trial(config, world, Ea2Variant::kLbEkfNoVr, 7);
  const auto lbi = run_ea2_trial(config, world, Ea2Variant::kLbEkfIVr, 7);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(lb.total_mse[static_cast<std::size_t>(k)], ekf.total_mse[static_cast<std::size_t>(k)], 1e-8);
    EXPECT_NEAR(lbi.total_mse[static_cast<std::size_t>(k)], ekf.total_mse[static_cast<std::size_t>(k)], 1e-8);
  }
}

}  // namespace
}  // namespace swarmloc::research
