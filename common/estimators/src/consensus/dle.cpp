#include "swarmloc/estimators/consensus/dle.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

#include "consensus/information_consensus.hpp"
#include "swarmloc/models/measurement_models.hpp"

namespace swarmloc::estimators::consensus {

void validate(const DleParams& params) {
  auto fail = [](const std::string& what) { throw std::invalid_argument("dle." + what); };
  const Eigen::Index d = params.target_dim;
  if (d < 1) fail("target_dim: must be >= 1");
  if (params.F.size() != 0) {
    if (params.F.rows() != d || params.F.cols() != d) fail("F: must be target_dim x target_dim");
    if (params.W.rows() != d || params.W.cols() != d) fail("W: must be target_dim x target_dim");
    if (!(params.initial_information > 0.0)) fail("initial_information: must be > 0 when tracking");
  }
  if (params.H.size() != 0 && (params.H.rows() != 2 || params.H.cols() != d))
    fail("H: must be 2 x target_dim");
  if (params.H.size() == 0 && d < 2) fail("H: required when target_dim < 2");
  if (params.initial_mean.size() != 0 && params.initial_mean.size() != d)
    fail("initial_mean: must have target_dim entries");
  if (!(params.initial_information >= 0.0)) fail("initial_information: must be >= 0");
}

Dle::Dle(const AgentSetup& setup, const DleParams& params) : setup_(setup), params_(params) {
  validate(params);
  const Eigen::Index d = params.target_dim;
  if (params.H.size() != 0) {
    H_ = params.H;
  } else {
    H_ = MatX::Zero(2, d);
    H_.leftCols(2).setIdentity();
  }
  omega_ = VecX::Zero(d);  // ω_{i,0} = 0 (docs/algorithms.md §4.2)
  Omega_ = params.initial_information * MatX::Identity(d, d);
  y_ = VecX::Zero(d);
  predicted_ = params.initial_mean.size() != 0 ? params.initial_mean : VecX::Zero(d);
}

Outbox Dle::published() const {
  Outbox outbox;
  outbox.information = InformationMessage{params_.target, omega_, Omega_, prior_world_step_};
  StateMessage state;
  state.mean_m = setup_.initial_guess_m;
  state.anchor = setup_.anchor;
  state.degree = static_cast<std::uint16_t>(degrees_.own);
  outbox.state = state;
  return outbox;
}

Outbox Dle::initial_outbox() const { return published(); }

bool Dle::shift_prior(VecX& omega, MatX& Omega, std::int64_t periods) const {
  const Eigen::Index d = params_.target_dim;
  if (periods < 0) {
    // Back in time: the mean by F⁻ᵏ and the covariance by F⁻ᵏ P F⁻ᵏᵀ, without taking the process noise
    // out again (that may leave no valid covariance), so the result is less certain than the true older
    // prior. In information form this needs no inverse: Ω' = (Fᵏ)ᵀ Ω Fᵏ, ω' = (Fᵏ)ᵀ ω.
    for (std::int64_t k = 0; k < -periods; ++k) {
      omega = params_.F.transpose() * omega;
      Omega = params_.F.transpose() * Omega * params_.F;
    }
    Omega = 0.5 * (Omega + Omega.transpose());
    return true;
  }
  const Eigen::LDLT<MatX> ldlt(Omega);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 0.0)) return false;
  VecX mean = ldlt.solve(omega);
  MatX P = ldlt.solve(MatX::Identity(d, d));
  for (std::int64_t k = 0; k < periods; ++k) {
    mean = params_.F * mean;
    P = params_.F * P * params_.F.transpose() + params_.W;
  }
  P = 0.5 * (P + P.transpose());
  Omega = P.ldlt().solve(MatX::Identity(d, d));
  Omega = 0.5 * (Omega + Omega.transpose());
  omega = Omega * mean;
  return true;
}

namespace {

// A prior further than this from the reference world step (a broken or hostile world step) is dropped: it
// says nothing about now, and the prediction loop must stay bounded.
constexpr std::int64_t kMaxGapPeriods = 1000;

}  // namespace

std::int64_t Dle::align_own_prior(std::int64_t batch_step) {
  // Tracking in a free run: priors are predicted to different world steps — this sensor's lags when
  // batches of world steps it never stepped on were carried into this one, and a neighbour's is one step
  // ahead or behind depending on when it stepped. Bring them all to one world step before mixing (a sum of
  // priors about different times puts the target between them): this batch's, else this sensor's prior's
  // (before its first reading there is none, and priors are mixed as they come).
  const bool tracking = params_.F.size() != 0;
  const std::int64_t reference_step = batch_step >= 0 ? batch_step : prior_world_step_;
  if (tracking && prior_world_step_ >= 0 && reference_step >= 0 && reference_step != prior_world_step_) {
    const std::int64_t gap = std::clamp(reference_step - prior_world_step_, -kMaxGapPeriods, kMaxGapPeriods);
    if (shift_prior(omega_, Omega_, gap)) {
      const Eigen::LDLT<MatX> ldlt(Omega_);
      if (ldlt.info() == Eigen::Success && ldlt.vectorD().minCoeff() > 0.0) predicted_ = ldlt.solve(omega_);
    }
  }
  if (tracking && reference_step >= 0) prior_world_step_ = reference_step;
  return reference_step;
}

bool Dle::add_observations(const MeasurementBatch& batch, VecX& omega_plus, MatX& Omega_plus) const {
  const Eigen::Index d = params_.target_dim;
  bool added = false;
  for (const TargetObservation& z : batch.targets) {
    if (z.target != params_.target || (z.kind != 0 && z.kind != 1) || !z.value.allFinite()) continue;
    const Eigen::LLT<Mat2> V(z.covariance);
    if (V.info() != Eigen::Success) continue;
    MatX H = H_;
    Vec2 value = z.value;
    if (z.kind == 1) {      // range–bearing: linearize at ŷ_pred (docs/algorithms.md §4.2)
      if (d < 2) continue;  // no target position to range to
      const Vec2 target = predicted_.head<2>();
      const auto r = models::range(setup_.initial_guess_m, target);
      const auto b = models::bearing(setup_.initial_guess_m, target);
      if (!r || !b) continue;
      H = MatX::Zero(2, d);
      H.block<1, 2>(0, 0) = r->d_xj;
      H.block<1, 2>(1, 0) = b->d_xj;
      const Vec2 linear_part = H * predicted_;
      value = Vec2(z.value(0) - r->value, models::bearing_residual(z.value(1), b->value)) + linear_part;
    }
    const MatX Vinv_H = V.solve(H);
    omega_plus += Vinv_H.transpose() * value;  // H_iᵀV_i⁻¹z_i
    Omega_plus += H.transpose() * Vinv_H;      // H_iᵀV_i⁻¹H_i
    added = true;
  }
  return added;
}

void Dle::update(const VecX& omega_plus, MatX& Omega_plus, std::int64_t batch_step) {
  const Eigen::Index d = params_.target_dim;
  Omega_plus = 0.5 * (Omega_plus + Omega_plus.transpose());
  const Eigen::LDLT<MatX> ldlt(Omega_plus);
  const Eigen::SelfAdjointEigenSolver<MatX> eig(Omega_plus, Eigen::EigenvaluesOnly);
  const bool invertible = eig.eigenvalues().minCoeff() > 1e-12 * std::max(1.0, eig.eigenvalues().maxCoeff());
  if (invertible) {
    y_ = ldlt.solve(omega_plus);
    predicted_ = y_;
    has_estimate_ = true;
    if (d >= 2) position_covariance_ = ldlt.solve(MatX::Identity(d, 2)).topRows<2>();
  }
  if (params_.F.size() != 0 && invertible) {  // [C-2]: predict from the updated Ω⁺
    const MatX P = ldlt.solve(MatX::Identity(d, d));
    MatX P_pred = params_.F * P * params_.F.transpose() + params_.W;
    P_pred = 0.5 * (P_pred + P_pred.transpose());
    Omega_ = P_pred.ldlt().solve(MatX::Identity(d, d));
    Omega_ = 0.5 * (Omega_ + Omega_.transpose());
    predicted_ = params_.F * y_;
    omega_ = Omega_ * predicted_;  // ω_{t+1} = Ω_{t+1} F ŷ_i(t+1)
    prior_world_step_ = batch_step >= 0 ? batch_step + 1 : -1;
  } else {  // a static target (no prediction), or Ω⁺ singular
    omega_ = omega_plus;
    Omega_ = Omega_plus;
  }
}

StepOutput Dle::step(const StepInput& input) {
  StepOutput out;
  const bool tracking = params_.F.size() != 0;
  const std::int64_t batch_step = input.measurements != nullptr ? input.measurements->world_step : -1;
  const std::int64_t reference_step = align_own_prior(batch_step);
  detail::AlignPrior align;
  if (tracking && reference_step >= 0) {
    align = [this, reference_step](InformationMessage& prior) {
      if (prior.world_step < 0) return true;  // not tied to a world step: taken as current
      const std::int64_t gap = reference_step - prior.world_step;
      if (gap > kMaxGapPeriods || gap < -kMaxGapPeriods) return false;
      prior.world_step = reference_step;
      return gap == 0 || shift_prior(prior.info_vec, prior.info_mat, gap);
    };
  }
  auto [omega_plus, Omega_plus] = detail::combine_priors(omega_, Omega_, params_.target, input,
                                                         params_.weights, degrees_, out.diagnostics, align);
  if (tracking && input.measurements == nullptr) {
    // Free run, no batch since the last step: no world time has passed that this sensor knows of. Mix the
    // neighbours' priors but neither predict nor move the estimate (it stays the one of the newest
    // reading, so it is not carried past the world's last step).
    omega_ = omega_plus;
    Omega_ = 0.5 * (Omega_plus + Omega_plus.transpose());
    out.outbox = published();
    return out;
  }
  if (input.measurements != nullptr && add_observations(*input.measurements, omega_plus, Omega_plus))
    out.diagnostics.updated = true;
  update(omega_plus, Omega_plus, batch_step);
  out.outbox = published();
  return out;
}

Estimate Dle::estimate() const {
  Estimate estimate;
  if (!has_estimate_ || params_.target_dim < 2) return estimate;
  estimate.mean_m = y_.head<2>();
  estimate.covariance = position_covariance_;
  estimate.valid = true;
  return estimate;
}

}  // namespace swarmloc::estimators::consensus
