#include "swarmloc/estimators/kalman/iekf.hpp"

#include <stdexcept>

#include "swarmloc/core/gaussian.hpp"

namespace swarmloc::estimators {

Iekf::Iekf(const AgentSetup& setup, const KalmanFilterParams& params)
    : setup_(setup),
      params_(params),
      Q_(params.process_noise_std_m * params.process_noise_std_m * Mat2::Identity()),
      x_(setup.initial_guess_m),
      P_(params.initial_std_m * params.initial_std_m * Mat2::Identity()) {  // P_0 = σ_0² I (§3.5)
  if (!(params.initial_std_m > 0.0) || !(params.process_noise_std_m >= 0.0)) {
    throw std::invalid_argument("iekf: initial_std_m must be > 0 and process_noise_std_m >= 0");
  }
  if (!setup.initial_guess_m.allFinite()) throw std::invalid_argument("iekf: initial guess is not finite");
  if (params.update_iterations < 1) throw std::invalid_argument("iekf: update_iterations must be >= 1");
}

Outbox Iekf::published() const {
  StateMessage state;
  state.mean_m = x_;
  state.anchor = setup_.anchor;
  state.degree = static_cast<std::uint16_t>(degree_);
  if (setup_.anchor) {
    state.covariance = Mat2::Zero();
  } else if (P_.allFinite()) {
    state.covariance = P_ + Q_;  // [B-5]: P_{k+1|k}
  } else {
    state.covariance = kUndefinedVarianceM2 * Mat2::Identity();
  }
  Outbox outbox;
  outbox.state = state;
  return outbox;
}

Outbox Iekf::initial_outbox() const { return published(); }

StepOutput Iekf::step(const StepInput& input) {
  StepOutput out;
  if (setup_.anchor) {
    out.outbox = published();
    return out;
  }
  // docs/algorithms.md §3.5: x̂_{k|k−1} = x̂_{k−1|k−1}, P_{k|k−1} = P_{k−1|k−1} + Q.
  const ProcessStep process = process_step(input, params_);
  const Vec2 x_pred = x_ + process.shift;
  const Mat2 P_pred = core::symmetrized(P_ + process.Q);

  const LinkSelection selection = collect_range_links(input, setup_.id, params_);
  Linearization rows = linearize_ranges(x_pred, selection.links);
  add_range_innovations(self_check_, rows, P_pred);  // self-check, docs/algorithms.md §1.6
  self_check_.end_step();
  out.diagnostics.ranges_gated = gate_ranges(rows, P_pred, params_.range_gate_chi2);
  if (input.measurements != nullptr) rows.fix = input.measurements->fix;
  out.diagnostics.neighbours_used = static_cast<int>(rows.jacobian.rows());
  out.diagnostics.neighbours_skipped = selection.skipped + rows.skipped;
  degree_ = out.diagnostics.neighbours_used;

  if (rows.empty()) {
    x_ = x_pred;
    P_ = P_pred;
  } else {
    KalmanUpdate update = kalman_update(x_pred, P_pred, rows);  // Gasparri & Pascucci eqs. (30)–(31)
    if (params_.update_iterations > 1 && positive_definite(P_pred)) {
      // The iterated update in information form: the same Gauss–Newton passes as the IEIF's, from the
      // prior Ψ = P_{k|k−1}⁻¹ (the two forms are algebraically equal, docs/algorithms.md §3.5).
      const Mat2 Psi_pred = core::symmetrized(Mat2(P_pred.inverse()));
      const InformationUpdate iterated =
          iterated_information_update(x_pred, Psi_pred, selection.links, rows,
                                      information_update(x_pred, Psi_pred, rows), params_.update_iterations);
      if (iterated.positive_definite)
        update = {iterated.mean, core::symmetrized(Mat2(iterated.Psi.inverse()))};
    }
    if (update.mean.allFinite() && update.covariance.allFinite()) {
      x_ = update.mean;
      P_ = update.covariance;
      out.diagnostics.updated = true;
    } else {
      x_ = x_pred;
      P_ = P_pred;
    }
  }
  out.outbox = published();
  return out;
}

Estimate Iekf::estimate() const {
  Estimate estimate;
  estimate.mean_m = x_;
  estimate.covariance = setup_.anchor ? Mat2::Zero() : P_;
  estimate.valid = setup_.anchor || core::is_symmetric_psd(P_);
  estimate.inconsistent = self_check_.inconsistent();
  return estimate;
}

}  // namespace swarmloc::estimators
