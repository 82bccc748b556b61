#include "swarmloc/estimators/kalman/ieif.hpp"

#include <stdexcept>
#include <string>

namespace swarmloc::estimators {

Ieif::Ieif(const AgentSetup& setup, const KalmanFilterParams& params)
    : setup_(setup),
      params_(params),
      Q_(params.process_noise_std_m * params.process_noise_std_m * Mat2::Identity()),
      x_(setup.initial_guess_m),
      Psi_(params.initial_information * Mat2::Identity()) {  // Ψ_0 = ε I (§3.2 initialization)
  if (!(params.initial_information >= 0.0) || !(params.process_noise_std_m >= 0.0)) {
    throw std::invalid_argument("ieif: initial_information and process_noise_std_m must be >= 0");
  }
  if (params.update_iterations < 1) throw std::invalid_argument("ieif: update_iterations must be >= 1");
  if (!setup.initial_guess_m.allFinite()) throw std::invalid_argument("ieif: initial guess is not finite");
}

Outbox Ieif::published() const {
  StateMessage state;
  state.mean_m = x_;
  state.anchor = setup_.anchor;
  state.degree = static_cast<std::uint16_t>(degree_);
  if (setup_.anchor) {
    state.covariance = Mat2::Zero();  // §3.1: anchors publish their position with zero covariance
  } else if (positive_definite(Psi_)) {
    state.covariance = Psi_.inverse() + Q_;  // [B-5]: P_{k+1|k} = Ψ_{k|k}⁻¹ + Q
  } else {
    state.covariance = kUndefinedVarianceM2 * Mat2::Identity();
  }
  Outbox outbox;
  outbox.state = state;
  return outbox;
}

Outbox Ieif::initial_outbox() const { return published(); }

StepOutput Ieif::step(const StepInput& input) {
  StepOutput out;
  if (setup_.anchor) {
    out.outbox = published();
    return out;
  }
  // Prediction, Gasparri & Pascucci eq. (48) (F = I): x̂_{k|k−1} = x̂_{k−1|k−1}, Ψ_{k|k−1} = (I + Ψ Q)⁻¹ Ψ.
  const ProcessStep process = process_step(input, params_);
  const Vec2 x_pred = x_ + process.shift;
  const Mat2 Psi_pred = predict_information(Psi_, process.Q);

  // Estimation, Gasparri & Pascucci eq. (49), over N_k(i) (§3.4 rules (1)–(3)).
  const LinkSelection selection = collect_range_links(input, setup_.id, params_);
  Linearization rows = linearize_ranges(x_pred, selection.links);
  // Self-check (docs/algorithms.md §1.6) on every range, gated or not; only once there is an estimate.
  if (positive_definite(Psi_pred)) add_range_innovations(self_check_, rows, Mat2(Psi_pred.inverse()));
  self_check_.end_step();
  // The gate needs a prior: P_{k|k−1} = Ψ_{k|k−1}⁻¹ once Ψ is PD (until then every range passes).
  if (params_.range_gate_chi2 > 0.0 && positive_definite(Psi_pred)) {
    out.diagnostics.ranges_gated = gate_ranges(rows, Mat2(Psi_pred.inverse()), params_.range_gate_chi2);
  }
  if (input.measurements != nullptr) rows.fix = input.measurements->fix;
  out.diagnostics.neighbours_used = static_cast<int>(rows.jacobian.rows());
  out.diagnostics.neighbours_skipped = selection.skipped + rows.skipped;
  degree_ = out.diagnostics.neighbours_used;

  if (rows.empty()) {  // rule (4): prediction only
    x_ = x_pred;
    Psi_ = Psi_pred;
  } else {
    InformationUpdate update = information_update(x_pred, Psi_pred, rows);
    if (params_.update_iterations > 1) {
      update = iterated_information_update(x_pred, Psi_pred, selection.links, rows, std::move(update),
                                           params_.update_iterations);
    }
    x_ = update.mean;
    Psi_ = update.Psi;
    out.diagnostics.updated = true;
  }
  out.outbox = published();
  return out;
}

Estimate Ieif::estimate() const {
  Estimate estimate;
  estimate.mean_m = x_;
  if (setup_.anchor) {
    estimate.covariance = Mat2::Zero();
    estimate.valid = true;
  } else if (positive_definite(Psi_)) {
    estimate.covariance = Psi_.inverse();
    estimate.valid = true;
  } else {
    estimate.covariance = kUndefinedVarianceM2 * Mat2::Identity();
    estimate.valid = false;
  }
  estimate.inconsistent = self_check_.inconsistent();
  return estimate;
}

}  // namespace swarmloc::estimators
