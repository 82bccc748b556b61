#pragma once
// The experiments of Khan et al. Sec. 5 (docs/algorithms.md §2.8) as library functions: no I/O, the caller
// prints. Randomness comes from caller-provided engines or seeds (filters themselves never draw).
#include <cstdint>
#include <random>
#include <vector>

#include "swarmloc/core/types.hpp"
#include "swarmloc/estimators/centralized/band_inversion.hpp"
#include "swarmloc/estimators/centralized/centralized_filter.hpp"
#include "swarmloc/estimators/centralized/relabeling.hpp"

namespace swarmloc::research {

namespace centralized = estimators::centralized;

// ---- E-A1 (Sec. 5.1, Fig. 2) ----
/// Random symmetric n×n matrix of bandwidth `bandwidth_of_a`: in-band off-diagonals U(−1, 1), diagonal
/// 15, then divided by the largest absolute entry (docs/algorithms.md §2.8).
MatX make_ea1_matrix(int n, int bandwidth_of_a, std::mt19937_64& rng);
/// ‖A⁻¹ − BandInv_L(A)‖_F for one fresh matrix.
double banded_inversion_error(
    int n, int bandwidth_of_a, int bandwidth, std::mt19937_64& rng,
    centralized::BandInversionMethod method = centralized::BandInversionMethod::kWindows);
/// The same error for several L on one matrix (A⁻¹ computed once).
std::vector<double> banded_inversion_errors(
    int n, int bandwidth_of_a, const std::vector<int>& bandwidths, std::mt19937_64& rng,
    centralized::BandInversionMethod method = centralized::BandInversionMethod::kWindows);

// ---- E-A3 (Sec. 5.3, Fig. 7) ----
struct VrBoundSample {
  int num_agents = 0;  ///< |V| ~ Poisson(λ l²)
  int phi_max = 0;     ///< φ_max(X, r) of eq. (33)
};
/// max over a of |{x_i ∈ [a, a + r]}| for sorted x (two-pointer scan, O(N)).
int max_strip_count(const std::vector<double>& sorted_x, double strip_width);
/// One sample of φ_max on a Poisson RGG in [0, l]² (only x-coordinates are drawn).
VrBoundSample vr_bandwidth_bound(double lambda, double side_m, double radius_m, std::mt19937_64& rng);

// ---- E-A2 (Sec. 5.2, Figs. 3–6) ----
struct Ea2Config {
  int num_agents = 30;
  int num_beacons = 8;
  double domain_m = 40.0;
  double sensing_radius_m = 15.0;
  double beacon_var = 2.0;    ///< σ_q (variance)
  double range_var = 10.0;    ///< σ_r (variance)
  double initial_var = 5.0;   ///< Σ_0 = initial_var · I, x̂(0) = x(0) + N(0, Σ_0)
  double process_var = 0.02;  ///< σ_p (variance); truth random-walks with it, v = 0 ([A-6])
  int steps = 100;
  int bandwidth = 20;  ///< L for the LB-EKF variants
  std::uint64_t config_seed = 3;
  bool relabel_from_truth = false;  ///< [A-5]: relabel from x̂(0) by default, from x(0) as an oracle
  centralized::BandInversionMethod inversion = centralized::BandInversionMethod::kWindows;
  bool compute_crb = true;
  /// Reject configurations whose VR bandwidth at x(0) exceeds this (< 0: no limit). The paper's Fig. 3
  /// configuration has β = 8 (Bandwidth(S) = 17 < L = 20), but uniform draws give β ≈ 11–16 (none
  /// <= 8 in 10⁵ draws); 9 is the largest β with Bandwidth(S) = 19 <= L = 20 (~1 draw in 10³).
  int max_vr_bandwidth = 9;
  int max_attempts = 100000;
};

/// The fixed configuration: positions x(0), beacon agents, disk graph at x(0); connected, rigid and
/// (if max_vr_bandwidth >= 0) with β_VR <= max_vr_bandwidth.
struct Ea2World {
  std::vector<Vec2> positions;
  std::vector<int> beacons;
  std::vector<centralized::Edge> edges;
  int natural_bandwidth = 0;  ///< β under the generation order
  int vr_bandwidth = 0;       ///< β under Alg. 3 applied to x(0)
  int attempts = 0;           ///< configurations drawn until one was accepted
};
/// Throws std::runtime_error if no acceptable configuration is found within max_attempts.
Ea2World make_ea2_world(const Ea2Config& config);

enum class Ea2Variant {
  kEkf,        ///< dense EKF
  kLbEkfVr,    ///< LB-EKF (Alg. 2) + VR
  kLbEkfNoVr,  ///< LB-EKF, generation-order labels
  kLbEkfIVr,   ///< LB-EKF-I + VR
  kLbEkfINoVr  ///< LB-EKF-I, generation-order labels
};

struct Ea2TrialResult {
  std::vector<double> total_mse;  ///< Σ_i ‖x_i(k) − x̂_i(k)‖², posterior at step k
  MatX agent_mse;                 ///< steps × agents, ‖x_i(k) − x̂_i(k)‖²
  std::vector<double> crb_total;  ///< tr(J_k⁻¹) on this trial's true trajectory (if compute_crb)
  MatX crb_agent;                 ///< steps × agents, tr([J_k⁻¹]_ii)
  int labels_bandwidth = 0;       ///< β of the initial graph under the labels the filter used
  int max_measurement_bandwidth = 0;
  int truncated_steps = 0;  ///< steps whose S_k had entries outside the band L
};

/// One Monte Carlo trial. Noise, initial error and the true random walk depend only on trial_seed,
/// so every variant sees the same draws for the same seed.
Ea2TrialResult run_ea2_trial(const Ea2Config& config, const Ea2World& world, Ea2Variant variant,
                             std::uint64_t trial_seed);
/// Convenience overload that builds the world from config.config_seed.
Ea2TrialResult run_ea2_trial(const Ea2Config& config, Ea2Variant variant, std::uint64_t trial_seed);

}  // namespace swarmloc::research
