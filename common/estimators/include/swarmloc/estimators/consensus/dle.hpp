#pragma once
// Distributed linear estimator of a target by information consensus (Atanasov et al. Algorithm 1, eqs.
// (6)–(7), docs/algorithms.md §4.2, §4.5).
#include <cstdint>
#include <string_view>

#include "swarmloc/estimators/consensus/metropolis.hpp"
#include "swarmloc/estimators/estimator.hpp"

namespace swarmloc::estimators::consensus {

struct DleParams {
  std::int32_t target = 0;  ///< only TargetObservations and InformationMessages of this target are used
  int target_dim = 2;       ///< d_y
  MatX F;                   ///< d_y×d_y; empty = static target (F = I, W = 0: no prediction)
  MatX W;                   ///< process covariance (tracking only)
  MatX H;  ///< 2×d_y observation matrix of kind-0 observations (value = H y + v); empty = [I₂ 0]
  /// Where kind-1 (range–bearing) observations are linearized before the first estimate exists; empty = 0.
  VecX initial_mean;
  double initial_information = 0.0;  ///< Ω_0 = ε I; use > 0 (e.g. 1e-6) when tracking (§4.2)
  MetropolisRule weights = MetropolisRule::kPlusOne;
};

/// Throws std::invalid_argument naming the offending field.
void validate(const DleParams& params);

/// One sensor of the DLE. Holds its prior (ω_{i,t}, Ω_{i,t}); each step():
///   ω⁺ = Σ_{j∈N_i∪{i}} κ_ij ω_{j,t} + Σ H_iᵀV⁻¹z,  Ω⁺ = Σ κ_ij Ω_{j,t} + Σ H_iᵀV⁻¹H_i,  ŷ = Ω⁺⁻¹ω⁺,
/// then (tracking) Ω_{t+1} = (F Ω⁺⁻¹ Fᵀ + W)⁻¹, ω_{t+1} = Ω_{t+1} F ŷ ([C-2]: prediction from the updated
/// Ω⁺). κ are Metropolis weights (own degree = |MeasurementBatch::neighbours| if given, else the number of
/// neighbours heard from; neighbour degrees from their STATE messages); the κ of neighbours whose
/// INFO message is missing are dropped and the rest renormalized (§4.5).
///
/// Tracking in a free run (docs/algorithms.md §4.5): every prior carries the world step it is predicted to
/// (InformationMessage::world_step), and a step first brings its own prior and each neighbour's to one
/// world step — its batch's, or without a batch its own prior's: forward by the prediction, back by
/// ω' = (Fᵏ)ᵀω, Ω' = (Fᵏ)ᵀΩFᵏ (the process noise is not taken out, so the result is never more certain than
/// the true older prior). A prior more than 1000 world steps away is dropped. A step without a batch mixes
/// the priors only — no prediction, and the estimate stays that of the newest reading. With a batch every
/// step, as in synchronous rounds, every prior is already at the batch's step and this is Algorithm 1
/// unchanged.
///
/// Observations of kind 0 are linear (z = H y + v). Observations of kind 1 are range and bearing from this
/// sensor (at AgentSetup::initial_guess_m) to the target's position y[0..1] (Atanasov et al. eq. (4), [C-1]:
/// atan2): linearized at the sensor's predicted estimate ŷ_pred = F ŷ (ŷ before any prediction; initial_mean
/// at first), as the pseudo-measurement z − h(ŷ_pred) + H ŷ_pred with the bearing residual wrapped (§4.2); a
/// target predicted within 1 nm of the sensor makes the row undefined and the observation is skipped.
///
/// Publishes INFO {target, ω_{i,t+1}, Ω_{i,t+1}} (the prior for the next step) and a STATE carrying the
/// sensor's (known) position and its degree, which neighbours need for the weights. estimate() reports the
/// target's position: ŷ's first two entries with the matching block of Ω⁺⁻¹ (invalid before the first
/// estimate); the whole target state is target_estimate().
class Dle final : public Estimator {
 public:
  Dle(const AgentSetup& setup, const DleParams& params);

  [[nodiscard]] std::string_view name() const override { return "dle"; }
  [[nodiscard]] Outbox initial_outbox() const override;
  StepOutput step(const StepInput& input) override;
  [[nodiscard]] Estimate estimate() const override;

  /// ŷ_i(t+1) after the last step; valid only if has_target_estimate().
  [[nodiscard]] const VecX& target_estimate() const { return y_; }
  [[nodiscard]] bool has_target_estimate() const { return has_estimate_; }
  /// The prior (ω, Ω) that was last published.
  [[nodiscard]] const VecX& info_vec() const { return omega_; }
  [[nodiscard]] const MatX& info_mat() const { return Omega_; }

 private:
  [[nodiscard]] Outbox published() const;
  /// Moves a prior (ω, Ω) `periods` world steps ahead (> 0, prediction) or back (< 0); false if a
  /// prediction finds Ω singular (the prior is left as it was).
  bool shift_prior(VecX& omega, MatX& Omega, std::int64_t periods) const;
  /// Tracking: predicts the own prior to the batch's world step (else keeps its own); returns that
  /// reference step (−1: none).
  std::int64_t align_own_prior(std::int64_t batch_step);
  /// Adds this target's observations in `batch` to (ω⁺, Ω⁺); true if any was added.
  bool add_observations(const MeasurementBatch& batch, VecX& omega_plus, MatX& Omega_plus) const;
  /// The estimate from (ω⁺, Ω⁺) (symmetrized here) and the next prior.
  void update(const VecX& omega_plus, MatX& Omega_plus, std::int64_t batch_step);

  AgentSetup setup_;
  DleParams params_;
  MatX H_;
  VecX omega_;
  MatX Omega_;
  VecX y_;
  VecX predicted_;                               ///< ŷ_pred: where kind-1 observations are linearized
  Mat2 position_covariance_ = Mat2::Identity();  ///< the position block of Ω⁺⁻¹
  /// Tracking: the world step the prior is predicted to (published with it); −1: none yet, or a static
  /// target, whose prior is not tied to a world step.
  std::int64_t prior_world_step_ = -1;
  bool has_estimate_ = false;
  ConsensusDegrees degrees_;
};

}  // namespace swarmloc::estimators::consensus
