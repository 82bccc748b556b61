#pragma once
// Reproduction experiment of Leng et al. Sec. 4 (docs/algorithms.md §5.4): 5 nodes, single anchor S_0 at the
// origin, NLOS paths only, cooperative multipath BP vs pairwise localization. No I/O; randomness from the
// seed.
#include <cstdint>
#include <vector>

namespace swarmloc::research {

struct MultipathExperimentConfig {
  int trials = 1000;
  int iterations = 50;
  double side_m = 10.0;        ///< S_1…S_4 uniform in [0, side]²; S_0 = (0, 0)
  double range_std_m = 3.0;    ///< [D-5]: std 3 m (default); std √3 m is the "variance 3" reading
  double doa_error_deg = 5.0;  ///< uniform on [−a, a] at each end independently
  std::vector<double> wall_angles_deg{0.0,
                                      45.0};  ///< one reflected path per wall per linked pair (R = #walls)
  double wall_margin_m = 5.0;                 ///< walls lie this far beyond the square's circumscribed circle
  double algorithm_sigma2 = -1.0;             ///< σ² used by BP/pairwise; ≤ 0: range_std² ([D-6])
  /// Not in Leng et al.: BP and pairwise also weight each path by what its angle errors do to eq. (1)
  /// (MultipathBpParams::doa_variance_rad2 = the uniform error's variance, doa_error² / 3).
  bool doa_aware_paths = false;
  /// Not in Leng et al.: exact GaBP, cavity messages instead of full beliefs ([D-4] ablation,
  /// MultipathBpParams::exact_messages).
  bool exact_messages = false;
  /// How a path's measured length is drawn. false (docs/algorithms.md §5.4): the image method's length plus
  /// N(0, range_std²), so the angle errors make eq. (1) wrong by what they move g. true (another reading of
  /// Leng et al. Sec. 4, whose theory takes eq. (1) as exact): the length eq. (1) predicts at the measured
  /// angles, g(θ̃_ij, θ̃_ji)ᵀ(s_i − s_j), plus N(0, range_std²); the angle errors then enter only through G.
  bool lengths_from_measured_angles = false;
  std::uint64_t seed = 1;
};

struct MultipathExperimentResult {
  /// [node][trial] signed errors x̂ − x of nodes 1…4 (index 0 unused, empty).
  std::vector<std::vector<double>> bp_x_error;
  std::vector<std::vector<double>> bp_y_error;
  std::vector<std::vector<double>> pairwise_x_error;
  std::vector<std::vector<double>> pairwise_y_error;
  /// Centralized baseline (not in Leng et al.): weighted least squares on all five links' paths at once
  /// (bp::centralized_from_paths), the best linear use of the same measurements.
  std::vector<std::vector<double>> centralized_x_error;
  std::vector<std::vector<double>> centralized_y_error;
  /// [l] mean |x error| over nodes 1…4 and trials after BP iteration l = 1…iterations ([0] = NaN).
  std::vector<double> bp_mean_abs_x_error;
  /// Trials in which some node's BP covariance grew between iterations (Thm. 1 says never).
  int covariance_increase_trials = 0;
  int trials_unlocalized = 0;  ///< BP left a node without a PD belief (excluded from the samples)
};

/// Links: S_1–S_0, S_2–S_0, S_3–S_1, S_4–S_2, S_3–S_4; S_3, S_4 have no path to S_0 (§5.4).
MultipathExperimentResult run_multipath_experiment(const MultipathExperimentConfig& config);

/// Quantile q ∈ [0, 1] of |values| (linear interpolation); NaN for an empty vector.
double abs_quantile(std::vector<double> values, double q);

}  // namespace swarmloc::research
