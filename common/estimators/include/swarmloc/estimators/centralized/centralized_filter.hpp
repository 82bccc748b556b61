#pragma once
// Centralized fusion-centre filters of Khan et al.: EKF (eqs. (10)–(12)), LB-EKF (Alg. 2, banded covariance)
// and LB-EKF-I (banded information, docs/algorithms.md §2.4 ). Not per-agent estimators: one object
// holds the whole network state. No transport, clock, RNG, I/O or logging inside.
#include <cstdint>
#include <memory>
#include <string_view>
#include <utility>
#include <vector>

#include "swarmloc/core/types.hpp"
#include "swarmloc/estimators/centralized/band_inversion.hpp"
#include "swarmloc/estimators/self_check.hpp"

namespace swarmloc::estimators::centralized {

/// One range y_ij = ‖x_i − x_j‖ + r_ij between agents i and j (original labels).
struct RangeEdgeMeasurement {
  int i = 0;
  int j = 0;
  double range_m = 0.0;
};

/// Everything the fusion centre receives for step k (docs/algorithms.md §2.7). Missing data: leave it out.
struct CentralizedMeasurements {
  std::vector<std::pair<int, Vec2>> beacon_fixes;  ///< (agent, y_b); 3-D: the planar part of y_b
  /// 3-D: the z of each beacon_fixes entry, in the same order (a fix informs all three axes). 2-D: empty
  /// (a planar filter does not read it).
  std::vector<double> beacon_fix_z;
  double beacon_var = 2.0;  ///< σ_q, a variance (m²) per coordinate
  std::vector<RangeEdgeMeasurement> ranges;
  double range_var = 10.0;            ///< σ_r, a variance (m²)
  std::vector<Vec2> velocity_inputs;  ///< v_i(k) (m per step, original labels); empty = zero
};

enum class CentralizedKind { kEkf, kLbEkf, kLbEkfI };

struct CentralizedFilterParams {
  double process_var = 0.02;  ///< σ_p, a variance (m²) per coordinate per step
  int bandwidth = 20;         ///< L in state (scalar) indices; clamped to n − 1; unused by the EKF
  BandInversionMethod inversion = BandInversionMethod::kWindows;
  std::vector<int> labels;  ///< π(agent) used internally (Khan et al. Alg. 3); empty = identity
  /// > 0: every pair within this radius is ranged (a static disk graph), so the self-check also flags an
  /// agent placed well inside the radius of one it has never ranged with (docs/algorithms.md §1.6). 0 = off.
  double disk_radius_m = 0.0;
};

/// S_k = H_kᵀR_k⁻¹H_k and b_k = H_kᵀR_k⁻¹(y − h(x̂)) in the relabeled order (docs/algorithms.md §2.1, [A-1]).
struct MeasurementInformation {
  MatX information;  ///< S_k, dense n×n
  VecX vector;       ///< b_k
};
/// Dense assembly at `linearization_point` (original labels, 2N). Ranges with ρ < 1e−9 are skipped.
MeasurementInformation assemble_measurement_information(const CentralizedMeasurements& measurements,
                                                        const VecX& linearization_point,
                                                        const std::vector<int>& labels);
/// The same in 3-D: `linearization_point` is 3N (x, y, z per agent), S_k is 3N×3N; beacon fixes read
/// beacon_fix_z.
MeasurementInformation assemble_measurement_information_3d(const CentralizedMeasurements& measurements,
                                                           const VecX& linearization_point,
                                                           const std::vector<int>& labels);

/// Shared step API. step(k) performs (with) the prediction from step k−1 (k >= 1; it applies the
/// velocity inputs given at step k−1) and the measurement update of step k. mean() and
/// covariance_block() then describe the posterior at step k. The state has D = dimension() coordinates
/// per agent (2: x, y; 3: x, y, z); the filters themselves are templates on D (src/centralized/).
class CentralizedFilter {
 public:
  virtual ~CentralizedFilter() = default;
  CentralizedFilter(const CentralizedFilter&) = delete;
  CentralizedFilter& operator=(const CentralizedFilter&) = delete;
  CentralizedFilter(CentralizedFilter&&) = delete;
  CentralizedFilter& operator=(CentralizedFilter&&) = delete;

  [[nodiscard]] virtual std::string_view name() const = 0;
  virtual void step(const CentralizedMeasurements& measurements) = 0;
  /// 2 or 3.
  [[nodiscard]] int dimension() const { return dimension_; }
  /// Posterior mean, D·N, original labels.
  [[nodiscard]] VecX mean() const;
  /// The planar part (x, y) of `agent`'s mean.
  [[nodiscard]] Vec2 agent_mean(int agent) const;
  /// The D coordinates of `agent`'s mean.
  [[nodiscard]] VecX agent_mean_full(int agent) const;
  /// Planar (x, y) 2×2 block of the (approximate) posterior covariance of `agent` (original label).
  [[nodiscard]] virtual Mat2 covariance_block(int agent) const = 0;
  /// The D×D diagonal block of `agent`.
  [[nodiscard]] virtual MatX covariance_block_full(int agent) const = 0;
  /// The filter's full posterior covariance as a dense D·N×D·N matrix in original labels (EKF: M_k;
  /// LB-EKF: the banded M̆_k; LB-EKF-I: Y_k⁻¹). O(n²) memory: for tests and small networks.
  [[nodiscard]] virtual MatX covariance_dense() const = 0;

  /// The self-check's verdict for `agent` (original label, docs/algorithms.md §1.6): the innovations of the
  /// range edges it is an endpoint of, over the last steps, do not fit the filter's covariance, or (with
  /// `disk_radius_m`) the filter places it well inside the radius of an agent it has never ranged with.
  [[nodiscard]] bool inconsistent(int agent) const;

  [[nodiscard]] int num_agents() const { return static_cast<int>(labels_.size()); }
  [[nodiscard]] std::int64_t steps_done() const { return steps_done_; }
  [[nodiscard]] const std::vector<int>& labels() const { return labels_; }
  /// Bandwidth of S_k in the internal order at the last step (Lemma 1), and how many of its
  /// lower-triangle entries fell outside the band L and were dropped ([A-5]: information truncated).
  /// LB-EKF keeps the band of S_k (Alg. 2 reads only windows, which stay PSD); LB-EKF-I needs all of
  /// Y_k PD, so it leaves out every range edge whose D×D cross block does not fit in the band.
  [[nodiscard]] int last_measurement_bandwidth() const { return last_measurement_bandwidth_; }
  [[nodiscard]] int last_truncated_entries() const { return last_truncated_entries_; }

 protected:
  /// initial_mean: x̂(0), D·N, original labels, for `agents` agents. Validates the sizes and the labels.
  CentralizedFilter(int dimension, const VecX& initial_mean, std::size_t agents,
                    const CentralizedFilterParams& params);
  /// Internal scalar index of coordinate c of `agent`.
  [[nodiscard]] int index(int agent, int c = 0) const {
    return dimension_ * labels_[static_cast<std::size_t>(agent)] + c;
  }

  std::vector<int> labels_;
  VecX x_;  ///< internal order
  std::int64_t steps_done_ = 0;
  int last_measurement_bandwidth_ = 0;
  int last_truncated_entries_ = 0;
  std::vector<RangeResidualCheck> self_checks_;  ///< one per agent, original labels
  std::vector<std::uint8_t> off_graph_;          ///< the disk-graph verdict, original labels

 private:
  int dimension_ = 2;
};

/// Builds a filter. `initial_mean` 2N (original labels), `initial_cov` N blocks of Σ_0.
/// Throws std::invalid_argument on inconsistent sizes or labels.
std::unique_ptr<CentralizedFilter> make_centralized_filter(CentralizedKind kind, const VecX& initial_mean,
                                                           const std::vector<Mat2>& initial_cov,
                                                           const CentralizedFilterParams& params);

/// The same in 3-D: `initial_mean` 3N (x, y, z per agent, original labels), `initial_cov` N 3×3 blocks.
/// `params.bandwidth` stays in scalar state indices (3 per agent).
std::unique_ptr<CentralizedFilter> make_centralized_filter_3d(CentralizedKind kind, const VecX& initial_mean,
                                                              const std::vector<Mat3>& initial_cov,
                                                              const CentralizedFilterParams& params);

/// "ekf", "lb-ekf", "lb-ekf-i".
std::string_view to_string(CentralizedKind kind);

}  // namespace swarmloc::estimators::centralized
