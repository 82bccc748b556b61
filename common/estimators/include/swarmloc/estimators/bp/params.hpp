#pragma once
// The BP family's parameters (Leng et al. Algorithm 1, docs/algorithms.md §5).

namespace swarmloc::estimators::bp {

struct MultipathBpParams {
  double sigma2 = 9.0;  ///< σ² of eq. (1) (variance, m²); default: std 3 m reading of [D-5]
  /// Variance of each measured angle of arrival (rad²). 0, as in Leng et al.: the angles in G_ji are taken as
  /// exact and σ² is a path's only noise. > 0 (not in Leng et al.): a path's variance also carries what its
  /// two angle errors do to eq. (1), see path_variances().
  double doa_variance_rad2 = 0.0;
  /// Exact GaBP (not in Leng et al., the ablation of [D-4]): a neighbour's message is built from its belief
  /// with this node's own contribution divided out (the cavity), so no evidence comes back over the edge it
  /// left by. false, as in Leng et al.: full beliefs are exchanged.
  bool exact_messages = false;
  double los_threshold = 1e-3;     ///< [D-2]
  double min_information = 1e-12;  ///< neighbours whose Λ_j has an eigenvalue below this are skipped (§5.2)
};

}  // namespace swarmloc::estimators::bp
