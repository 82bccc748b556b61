#pragma once
// Shared kernels of the distributed Kalman family (IEIF and IEKF, docs/algorithms.md §3). Pure functions,
// exposed so that tests can check each equation on its own.
#include <Eigen/LU>
#include <optional>
#include <vector>

#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/kalman/params.hpp"
#include "swarmloc/estimators/messages.hpp"
#include "swarmloc/estimators/self_check.hpp"

namespace swarmloc::estimators {

/// Variance (m²) published for a position that is not yet defined (Ψ not PD). Finite so that it
/// survives transport; far above KalmanFilterParams::max_neighbour_variance_m2, so neighbours skip it.
inline constexpr double kUndefinedVarianceM2 = 1e12;

/// One range z^(i,j) paired with neighbour j's predicted state (docs/algorithms.md §3.2 inputs).
struct RangeLink {
  AgentId peer = 0;
  Vec2 neighbour_mean_m = Vec2::Zero();      ///< x̂_{k|k−1}^(j)
  Mat2 neighbour_covariance = Mat2::Zero();  ///< P_j (after stale inflation)
  double range_m = 0.0;                      ///< z^(i,j)
  double std_m = 0.0;                        ///< σ_r of this range
};

struct LinkSelection {
  std::vector<RangeLink> links;
  int skipped = 0;  ///< ranges without a usable state message + state messages without a range
};

/// Staleness a of a neighbour message (§3.4 rule (2)). A message sent at the sender's step s already
/// holds the prediction for step s + 1 ([B-5]), so it is fresh for the receiver's step s + 1:
/// a = max(0, local_step − sender_step − 1).
std::int64_t staleness_steps(std::int64_t local_step, std::int64_t sender_step);

/// §3.4 rules (1)–(3): pairs every range in the batch with the newest state message of its peer.
/// Skips peers without a message, with a non-finite state, or with trace(P_j) above
/// params.max_neighbour_variance_m2 (after inflation). Non-anchor P_j is inflated by a·Q when
/// params.inflate_stale. Returns no links if the batch or inbox is missing.
LinkSelection collect_range_links(const StepInput& input, AgentId self, const KalmanFilterParams& params);

/// The measurement rows of one step, linearized at x̂_{k|k−1}^(i) (docs/algorithms.md §3.2):
/// row m is J_i(m, :) = u_ijᵀ, innovation ν_m = z − d̂_ij, variance r̃_m = σ_r² + u_ijᵀ P_j u_ij.
/// Rows are independent (R̃ diagonal). An optional linear absolute fix adds H = I₂ with covariance R.
struct Linearization {
  Eigen::Matrix<double, Eigen::Dynamic, 2> jacobian;  ///< J_i (M×2)
  VecX innovation;                                    ///< ν (M)
  VecX variance;                                      ///< diag R̃ (M)
  std::optional<AbsoluteFix> fix;                     ///< used only if its covariance is PD
  int skipped = 0;                                    ///< links dropped (ρ < 1e−9 or r̃ not > 0)
  std::vector<std::size_t> link_of_row;               ///< row m came from links[link_of_row[m]]

  [[nodiscard]] bool empty() const { return jacobian.rows() == 0 && !fix.has_value(); }
};

/// Builds J_i, ν and R̃ for `links` at the receiver's predicted position `x_i` (Gasparri & Pascucci eqs. (44),
/// (49)).
Linearization linearize_ranges(const Vec2& x_i, const std::vector<RangeLink>& links);

/// Chi-square innovation gate on the range rows (one degree of freedom per row): drops row m when
/// ν_m² > chi2_gate · s_m, with the innovation variance s_m = J_i(m, :) P_pred J_i(m, :)ᵀ + r̃_m (the
/// receiver's own predicted covariance plus the interlaced range variance). Keeps every row when
/// chi2_gate <= 0 or P_pred is not finite and PSD (no prior to gate against), and when more than half of
/// the rows are outside the gate (then the prediction, not the ranges, is what is off — gating would lock
/// a wrong early estimate in). The absolute fix is not gated. Returns the number of rows dropped.
int gate_ranges(Linearization& rows, const Mat2& P_pred, double chi2_gate);

/// Feeds the self-check (docs/algorithms.md §1.6) with a step's range rows linearized at the prediction
/// (before any gating: a range the gate drops still tells whether the estimate fits the data): ν_m over
/// s_m = r̃_m + J_i(m, :) P_pred J_i(m, :)ᵀ, the gate's innovation variance. Adds nothing while P_pred is not
/// finite and PSD (no estimate yet to test). The caller closes the step (RangeResidualCheck::end_step).
void add_range_innovations(RangeResidualCheck& check, const Linearization& rows, const Mat2& P_pred);

/// Gasparri & Pascucci eq. (48) with F = I in the singular-safe form Ψ_{k|k−1} = (I + Ψ Q)⁻¹ Ψ
/// (docs/algorithms.md §3.2).
Mat2 predict_information(const Mat2& Psi, const Mat2& Q);

/// Result of the information-form estimation step (Gasparri & Pascucci eq. (49), docs/algorithms.md §3.2).
struct InformationUpdate {
  Mat2 Phi = Mat2::Zero();   ///< Φ = J_iᵀ R̃⁻¹ J_i (+ R_fix⁻¹)
  Vec2 iota = Vec2::Zero();  ///< ι = J_iᵀ R̃⁻¹ z′ (+ R_fix⁻¹ z_fix), z′ = ν + J_i x̂_i ([B-3])
  Mat2 Psi = Mat2::Zero();   ///< Ψ_{k|k} = Ψ_{k|k−1} + Φ
  Vec2 y = Vec2::Zero();     ///< ŷ_{k|k} = ŷ_{k|k−1} + ι
  Vec2 mean = Vec2::Zero();  ///< x̂_{k|k} = Ψ_{k|k}⁻¹ ŷ_{k|k}, or x̂_{k|k−1} if Ψ_{k|k} is not PD
  bool positive_definite = false;
};

/// Information update from the predicted pair (x̂_{k|k−1}, Ψ_{k|k−1}); ŷ_{k|k−1} = Ψ_{k|k−1} x̂_{k|k−1}.
/// `rows` are linearized at `linearized_at` (x̂_{k|k−1} in Gasparri & Pascucci): z′ = ν + J_i·linearized_at.
InformationUpdate information_update(const Vec2& x_pred, const Mat2& Psi_pred, const Linearization& rows);
InformationUpdate information_update(const Vec2& x_pred, const Mat2& Psi_pred, const Linearization& rows,
                                     const Vec2& linearized_at);

/// The iterated update (KalmanFilterParams::update_iterations): up to `passes` Gauss–Newton steps on the
/// step's cost — the prior term (x − x̂_{k|k−1})ᵀΨ_{k|k−1}(x − x̂_{k|k−1}) plus each range's squared residual
/// over its interlaced variance (and the fix's) — as the iterated extended Kalman filter. `first` is the
/// update linearized at x̂_{k|k−1} (after any gating: only the links of its rows are used again). Each step
/// is halved until it lowers the cost; the update is then linearized again at the new point. Stops when a
/// step is below 1 nm, no halving lowers the cost, or a linearization leaves Ψ_{k|k} not PD. The result's
/// mean is the last point reached and its Ψ_{k|k} that of the linearization there.
InformationUpdate iterated_information_update(const Vec2& x_pred, const Mat2& Psi_pred,
                                              const std::vector<RangeLink>& links, const Linearization& rows,
                                              InformationUpdate first, int passes);

struct KalmanUpdate {
  Vec2 mean = Vec2::Zero();
  Mat2 covariance = Mat2::Zero();
};

/// Kalman-form update (Gasparri & Pascucci eqs. (30)–(32), docs/algorithms.md §3.5) with the Joseph form
/// P = (I − K H) P (I − K H)ᵀ + K R Kᵀ, S = H P Hᵀ + R (M×M).
KalmanUpdate kalman_update(const Vec2& x_pred, const Mat2& P_pred, const Linearization& rows);

/// One step of the process model x_k = x_{k−1} + w, Q = process_noise_std_m²·I (Gasparri & Pascucci eq.
/// (37)); a MotionInput in the batch adds v·dt to the mean and its process covariance to Q.
struct ProcessStep {
  Vec2 shift = Vec2::Zero();
  Mat2 Q = Mat2::Zero();
};
ProcessStep process_step(const StepInput& input, const KalmanFilterParams& params);

/// True if `m` is finite, symmetric and PD with det > 1e−13·tr² (rejects numerically rank-1 matrices).
bool positive_definite(const Mat2& m);

}  // namespace swarmloc::estimators
