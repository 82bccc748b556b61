#include "swarmloc/estimators/kalman/kernels.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "swarmloc/core/gaussian.hpp"
#include "swarmloc/models/measurement_models.hpp"

namespace swarmloc::estimators {

std::int64_t staleness_steps(std::int64_t local_step, std::int64_t sender_step) {
  return std::max<std::int64_t>(0, local_step - sender_step - 1);
}

LinkSelection collect_range_links(const StepInput& input, AgentId self, const KalmanFilterParams& params) {
  LinkSelection selection;
  if (input.measurements == nullptr) return selection;  // §3.4 rule (4): prediction only
  const auto& ranges = input.measurements->ranges;
  if (input.inbox == nullptr) {
    selection.skipped = static_cast<int>(ranges.size());
    return selection;
  }
  // Rule (1): the newest message per sender.
  std::unordered_map<AgentId, const Received<StateMessage>*> newest;
  for (const auto& received : input.inbox->states) {
    if (received.sender == self) continue;
    auto [it, inserted] = newest.try_emplace(received.sender, &received);
    if (!inserted && received.sender_step > it->second->sender_step) it->second = &received;
  }
  const double q = params.process_noise_std_m * params.process_noise_std_m;
  std::unordered_map<AgentId, bool> measured;
  for (const auto& range : ranges) {
    const auto found = newest.find(range.peer);
    if (range.peer == self || found == newest.end()) {
      ++selection.skipped;  // rule (3): no message
      continue;
    }
    measured[range.peer] = true;
    const Received<StateMessage>& received = *found->second;
    Mat2 P_j = core::symmetrized(received.message.covariance);
    if (params.inflate_stale && !received.message.anchor) {
      // Rule (2): P_j ← P_j + a·Q^(j) (random-walk model, §3.4).
      P_j +=
          static_cast<double>(staleness_steps(input.local_step, received.sender_step)) * q * Mat2::Identity();
    }
    const bool usable = received.message.mean_m.allFinite() && P_j.allFinite() &&
                        std::isfinite(range.range_m) && std::isfinite(range.std_m) && range.std_m >= 0.0 &&
                        P_j.trace() <= params.max_neighbour_variance_m2;
    if (!usable) {
      ++selection.skipped;  // effectively infinite P_j: r̃_j → ∞ (§3.2)
      continue;
    }
    selection.links.push_back(
        RangeLink{range.peer, received.message.mean_m, P_j, range.range_m, range.std_m});
  }
  for (const auto& [sender, received] : newest) {
    if (!measured.contains(sender)) ++selection.skipped;  // rule (3): no range this step
  }
  return selection;
}

Linearization linearize_ranges(const Vec2& x_i, const std::vector<RangeLink>& links) {
  Linearization rows;
  rows.link_of_row.reserve(links.size());
  rows.jacobian.resize(static_cast<Eigen::Index>(links.size()), 2);
  rows.innovation.resize(static_cast<Eigen::Index>(links.size()));
  rows.variance.resize(static_cast<Eigen::Index>(links.size()));
  Eigen::Index m = 0;
  for (const auto& link : links) {
    const auto h = models::range(x_i, link.neighbour_mean_m);
    if (!h) {
      ++rows.skipped;  // ρ < 1e−9: no direction (§1.1)
      continue;
    }
    const models::Row2& u = h->d_xi;  // u_ijᵀ, Gasparri & Pascucci eq. (44)
    const double r_tilde =
        link.std_m * link.std_m + u * link.neighbour_covariance * u.transpose();  // interlacing
    if (!(r_tilde > 0.0) || !std::isfinite(r_tilde)) {
      ++rows.skipped;
      continue;
    }
    rows.jacobian.row(m) = u;
    rows.innovation(m) = link.range_m - h->value;  // ν_j = z − d̂_ij
    rows.variance(m) = r_tilde;
    rows.link_of_row.push_back(static_cast<std::size_t>(&link - links.data()));
    ++m;
  }
  rows.jacobian.conservativeResize(m, 2);
  rows.innovation.conservativeResize(m);
  rows.variance.conservativeResize(m);
  return rows;
}

int gate_ranges(Linearization& rows, const Mat2& P_pred, double chi2_gate) {
  if (!(chi2_gate > 0.0) || !P_pred.allFinite() || !core::is_symmetric_psd(P_pred)) return 0;
  const Eigen::Index count = rows.jacobian.rows();
  std::vector<bool> outside(static_cast<std::size_t>(count), false);
  Eigen::Index rejected = 0;
  for (Eigen::Index m = 0; m < count; ++m) {
    const models::Row2 u = rows.jacobian.row(m);
    const double s = rows.variance(m) + (u * P_pred * u.transpose()).value();
    const double nu = rows.innovation(m);
    if (nu * nu > chi2_gate * s) {
      outside[static_cast<std::size_t>(m)] = true;
      ++rejected;
    }
  }
  // If most ranges disagree with the prediction, the prediction is what is off (a wrong early estimate
  // with an overconfident covariance): gating them would lock the error in, so every range is used.
  if (2 * rejected > count) return 0;
  Eigen::Index kept = 0;
  for (Eigen::Index m = 0; m < count; ++m) {
    if (outside[static_cast<std::size_t>(m)]) continue;
    if (kept != m) {
      rows.jacobian.row(kept) = rows.jacobian.row(m);
      rows.innovation(kept) = rows.innovation(m);
      rows.variance(kept) = rows.variance(m);
      if (!rows.link_of_row.empty()) {
        rows.link_of_row[static_cast<std::size_t>(kept)] = rows.link_of_row[static_cast<std::size_t>(m)];
      }
    }
    ++kept;
  }
  rows.jacobian.conservativeResize(kept, 2);
  rows.innovation.conservativeResize(kept);
  rows.variance.conservativeResize(kept);
  if (!rows.link_of_row.empty()) rows.link_of_row.resize(static_cast<std::size_t>(kept));
  return static_cast<int>(count - kept);
}

void add_range_innovations(RangeResidualCheck& check, const Linearization& rows, const Mat2& P_pred) {
  if (!P_pred.allFinite() || !core::is_symmetric_psd(P_pred)) return;
  for (Eigen::Index m = 0; m < rows.jacobian.rows(); ++m) {
    const models::Row2 u = rows.jacobian.row(m);
    check.add(rows.innovation(m), rows.variance(m) + (u * P_pred * u.transpose()).value());
  }
}

Mat2 predict_information(const Mat2& Psi, const Mat2& Q) {
  // Gasparri & Pascucci eq. (48): Ψ_{k|k−1} = (I + Ψ Q)⁻¹ Ψ — valid for singular Ψ.
  const Mat2 L = (Mat2::Identity() + Psi * Q).inverse();
  return core::symmetrized(L * Psi);
}

ProcessStep process_step(const StepInput& input, const KalmanFilterParams& params) {
  ProcessStep step;
  step.Q = params.process_noise_std_m * params.process_noise_std_m * Mat2::Identity();
  if (input.measurements != nullptr && input.measurements->motion) {
    const MotionInput& motion = *input.measurements->motion;
    if (motion.velocity_mps.allFinite() && std::isfinite(motion.dt_s))
      step.shift = motion.velocity_mps * motion.dt_s;
    if (motion.process_cov.allFinite()) step.Q += core::symmetrized(motion.process_cov);
  }
  return step;
}

bool positive_definite(const Mat2& m) {
  // Sylvester for 2×2 plus a scale-free floor λ_min/λ_max ≳ 1e−13 (det/tr² bounds it), so that a
  // rank-1 matrix with rounding noise does not pass.
  constexpr double kMinDetOverTrace2 = 1e-13;
  if (!core::is_symmetric_psd(m)) return false;
  const double trace = m.trace();
  return m(0, 0) > 0.0 && m.determinant() > kMinDetOverTrace2 * trace * trace;
}

namespace {

const AbsoluteFix* usable_fix(const Linearization& rows) {
  if (rows.fix && rows.fix->position_m.allFinite() && positive_definite(rows.fix->covariance))
    return &*rows.fix;
  return nullptr;
}

/// Φ = Σ u uᵀ/r̃ (+ R_fix⁻¹) and b = Σ u ν/r̃ (+ R_fix⁻¹ (z_fix − x̂)): the information both update forms
/// need (Gasparri & Pascucci eq. (49); the Kalman form through the push-through identity).
struct RangeRowsInformation {
  Mat2 Phi = Mat2::Zero();
  Vec2 b = Vec2::Zero();
};

RangeRowsInformation row_information(const Vec2& x_pred, const Linearization& rows) {
  RangeRowsInformation out;
  for (Eigen::Index m = 0; m < rows.jacobian.rows(); ++m) {
    const Vec2 u = rows.jacobian.row(m).transpose();
    out.Phi += u * u.transpose() / rows.variance(m);
    out.b += u * rows.innovation(m) / rows.variance(m);
  }
  if (const AbsoluteFix* fix = usable_fix(rows)) {
    const Mat2 R_inv = fix->covariance.inverse();  // linear row H = I₂
    out.Phi += R_inv;
    out.b += R_inv * (fix->position_m - x_pred);
  }
  return out;
}

}  // namespace

InformationUpdate information_update(const Vec2& x_pred, const Mat2& Psi_pred, const Linearization& rows) {
  return information_update(x_pred, Psi_pred, rows, x_pred);
}

InformationUpdate information_update(const Vec2& x_pred, const Mat2& Psi_pred, const Linearization& rows,
                                     const Vec2& linearized_at) {
  InformationUpdate out;
  // Gasparri & Pascucci eq. (49), docs/algorithms.md §3.2: Φ = Σ u uᵀ/r̃, ι = Σ u z′/r̃, z′ = ν + uᵀ x̂_i, i.e.
  // ι = b + Φ x̂_i, with x̂_i the point the rows are linearized at.
  const RangeRowsInformation info = row_information(linearized_at, rows);
  out.Phi = info.Phi;
  out.iota = info.b + info.Phi * linearized_at;
  out.Phi = core::symmetrized(out.Phi);
  out.Psi = core::symmetrized(Psi_pred + out.Phi);
  out.y = Psi_pred * x_pred + out.iota;
  out.positive_definite = positive_definite(out.Psi);
  out.mean = x_pred;  // kept unchanged if Ψ_{k|k} is not PD (§3.2)
  if (out.positive_definite) {
    const Eigen::LLT<Mat2> llt(out.Psi);
    if (llt.info() == Eigen::Success) {
      out.mean = llt.solve(out.y);
    } else {
      out.positive_definite = false;
    }
  }
  return out;
}

namespace {

/// The cost the iterated update minimizes: the prior term plus each range's squared residual over its
/// interlaced variance (and the fix's), all at x.
double update_cost(const Vec2& x, const Vec2& x_pred, const Mat2& Psi_pred,
                   const std::vector<RangeLink>& links, const std::optional<AbsoluteFix>& fix) {
  const Vec2 from_prior = x - x_pred;
  double cost = from_prior.dot(Psi_pred * from_prior);
  Linearization rows = linearize_ranges(x, links);
  cost += (rows.innovation.array().square() / rows.variance.array()).sum();
  rows.fix = fix;
  if (const AbsoluteFix* usable = usable_fix(rows)) {
    const Vec2 residual = usable->position_m - x;
    cost += residual.dot(usable->covariance.inverse() * residual);
  }
  return cost;
}

}  // namespace

InformationUpdate iterated_information_update(const Vec2& x_pred, const Mat2& Psi_pred,
                                              const std::vector<RangeLink>& links, const Linearization& rows,
                                              InformationUpdate first, int passes) {
  std::vector<RangeLink> kept;  // the links of the first pass's rows (after gating)
  kept.reserve(rows.link_of_row.size());
  for (const std::size_t link : rows.link_of_row) kept.push_back(links[link]);
  // Gauss–Newton with step halving: a pass's step is taken only as far as it lowers the cost. From a
  // diffuse prior a full step can overshoot by tens of metres (the first linearization is far off).
  InformationUpdate update = std::move(first);  // linearized at `at`, its mean the next Gauss–Newton point
  Vec2 at = x_pred;
  std::optional<double> cost;  // at `at`; evaluated only once a step needs checking (not when converged)
  for (int pass = 0; pass < passes && update.positive_definite; ++pass) {
    const Vec2 step = update.mean - at;
    if (!(step.norm() >= 1e-9)) {  // converged; below rounding the cost cannot tell the halvings apart
      at = update.mean;
      break;
    }
    if (!cost) cost = update_cost(at, x_pred, Psi_pred, kept, rows.fix);
    bool lowered = false;
    Vec2 next = at;
    for (int halving = 0; halving < 30 && !lowered; ++halving) {
      next = at + std::ldexp(1.0, -halving) * step;
      const double next_cost = update_cost(next, x_pred, Psi_pred, kept, rows.fix);
      if (next_cost < *cost) {
        cost = next_cost;
        lowered = true;
      }
    }
    if (!lowered) break;  // `at` is a local minimum to within rounding
    const double moved = (next - at).norm();
    at = next;
    Linearization relinearized = linearize_ranges(at, kept);
    relinearized.fix = rows.fix;
    InformationUpdate relinearized_update = information_update(x_pred, Psi_pred, relinearized, at);
    if (!relinearized_update.positive_definite) break;
    update = relinearized_update;
    if (!(moved >= 1e-9)) break;
  }
  // The estimate is the last point reached, its information that of the linearization there.
  update.mean = at;
  update.y = update.Psi * at;
  return update;
}

KalmanUpdate kalman_update(const Vec2& x_pred, const Mat2& P_pred, const Linearization& rows) {
  // Gasparri & Pascucci eqs. (30)–(32): S = H P Hᵀ + R̃, K = P Hᵀ S⁻¹, Joseph form. R̃ is block diagonal
  // (independent ranges, one 2×2 fix), so by the push-through identity K = (I + P A)⁻¹ P Hᵀ R̃⁻¹ with A = Hᵀ
  // R̃⁻¹ H: only A and b = Hᵀ R̃⁻¹ ν are needed, O(M) instead of factoring the M×M S (360 nodes: M = 359).
  // P_pred is never inverted; I + P A is invertible because P and A are PSD.
  if (rows.jacobian.rows() == 0 && usable_fix(rows) == nullptr) return KalmanUpdate{x_pred, P_pred};
  const RangeRowsInformation info = row_information(x_pred, rows);
  const Mat2& A = info.Phi;
  const Vec2& b = info.b;
  const Mat2 M_inv = (Mat2::Identity() + P_pred * A).inverse();
  const Mat2 KH = M_inv * P_pred * A;  // K H
  const Mat2 I_KH = Mat2::Identity() - KH;
  KalmanUpdate out;
  out.mean = x_pred + M_inv * (P_pred * b);  // x + K ν
  // Joseph form (I − K H) P (I − K H)ᵀ + K R̃ Kᵀ, with K R̃ Kᵀ = M⁻¹ P A P M⁻ᵀ.
  out.covariance =
      core::symmetrized(I_KH * P_pred * I_KH.transpose() + M_inv * P_pred * A * P_pred * M_inv.transpose());
  return out;
}

}  // namespace swarmloc::estimators
