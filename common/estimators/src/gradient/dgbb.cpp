#include "swarmloc/estimators/gradient/dgbb.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>

namespace swarmloc::estimators::gradient {
namespace {

constexpr double kMinCurvature = 1e-300;  // docs/algorithms.md §6.2 [E-4]

bool bb_step_valid(double rho, double psi, double alpha) {
  return psi > kMinCurvature && std::isfinite(alpha) && alpha > 0.0 && std::isfinite(rho);
}

}  // namespace

void validate(const DgBbParams& params) {
  auto fail = [](const std::string& what) { throw std::invalid_argument("dgbb." + what); };
  if (params.consensus_rounds < 0) fail("consensus_rounds: must be >= 0");
  if (params.warmup_updates < 0) fail("warmup_updates: must be >= 0");
  if (!(params.warmup_step > 0.0)) fail("warmup_step: must be > 0");
  if (!(params.abs_tol >= 0.0)) fail("abs_tol: must be >= 0");
  if (params.max_updates < 1) fail("max_updates: must be >= 1");
  if (!(params.fixed_step > 0.0)) fail("fixed_step: must be > 0");
  if (!(params.step_length > 0.0)) fail("step_length: must be > 0");
  if (!(params.grad_scale == 1.0 || params.grad_scale == 2.0)) fail("grad_scale: must be 1 or 2");
  if (!(params.max_step > 0.0)) fail("max_step: must be > 0");
  if (!(params.max_move_fraction >= 0.0 && std::isfinite(params.max_move_fraction)))
    fail("max_move_fraction: must be finite and >= 0");
}

DgBb::DgBb(const AgentSetup& setup, const DgBbParams& params)
    : setup_(setup),
      params_(params),
      p_(setup.initial_guess_m),
      p_prev_(Vec2::Zero()),  // convention p^(−1) = 0, D(p^(−1)) = 0 (used only if τ_wup = 0)
      active_(!setup.anchor),
      last_alpha_(std::numeric_limits<double>::quiet_NaN()),
      last_valid_alpha_(params.warmup_step) {
  validate(params);
  if (!setup.initial_guess_m.allFinite()) throw std::invalid_argument("dgbb: initial guess is not finite");
}

std::string_view DgBb::name() const {
  switch (params_.rule) {
    case StepRule::kConsensusBb:
      return "dgbb";
    case StepRule::kLocalBb:
      return "local_bb";
    case StepRule::kFixed:
      return "fixed_step";
    case StepRule::kStepLength:
      return "step_length";
  }
  return "dgbb";
}

void DgBb::publish(Outbox& outbox, bool with_consensus) const {
  StateMessage state;
  state.mean_m = p_;
  state.covariance = Mat2::Zero();
  state.anchor = setup_.anchor;
  state.active = active();
  state.degree = static_cast<std::uint16_t>(range_count_);
  outbox.state = state;
  if (with_consensus) outbox.consensus.push_back(ConsensusMessage{tau_, round_, {rho_, psi_}});
}

Outbox DgBb::initial_outbox() const {
  Outbox outbox;
  publish(outbox, false);
  return outbox;
}

std::size_t DgBb::peer_index(AgentId id) {
  auto it = std::lower_bound(peers_.begin(), peers_.end(), id,
                             [](const Peer& p, AgentId key) { return p.id < key; });
  if (it == peers_.end() || it->id != id) {
    Peer added;
    added.id = id;
    it = peers_.insert(it, added);
  }
  return static_cast<std::size_t>(it - peers_.begin());
}

DgBb::Peer& DgBb::inbox_peer(std::size_t& hint, AgentId id) {
  if (hint >= peers_.size() || peers_[hint].id != id) hint = peer_index(id);
  return peers_[hint];
}

bool DgBb::direction(Vec2& D) const { return direction_at(p_, D); }

bool DgBb::direction_at(const Vec2& position, Vec2& D) const {
  D = Vec2::Zero();
  for (const Peer& peer : peers_) {
    if (!peer.has_range) continue;
    if (!peer.have_state) return false;
    const Vec2 delta = position - peer.position;
    // g_ij (p_i − p_j), Calafiore et al. eq. (13) [E-1]
    D += (delta.squaredNorm() - peer.range * peer.range) * delta;
  }
  D *= params_.grad_scale;
  return true;
}

double DgBb::capped_bb_step(double alpha, const Vec2& D) {
  alpha = std::min(alpha, params_.max_step);
  if (params_.max_move_fraction > 0.0 && range_count_ > 0) {
    double shortest = std::numeric_limits<double>::infinity();
    for (const Peer& peer : peers_) {
      if (peer.has_range) shortest = std::min(shortest, peer.range);
    }
    const double max_move = params_.max_move_fraction * shortest;
    const double move = alpha * D.norm();
    if (move > max_move && max_move > 0.0) {
      alpha *= max_move / move;
      if (active_) ++trust_region_count_;
    }
  }
  return alpha;
}

void DgBb::apply_update(const Vec2& D, double alpha) {
  if (active_ && !setup_.anchor) {
    const Vec2 next = p_ - alpha * D;  // Calafiore et al. eq. (14)
    const double correction = (next - p_).norm();
    p_prev_ = p_;
    p_ = next;
    if (!(correction > params_.abs_tol)) active_ = false;  // [E-3]: new vs old iterate; [E-5]
  } else {
    p_prev_ = p_;
  }
  D_prev_ = D;
  have_prev_ = true;
  ++tau_;
}

void DgBb::consensus_round() {
  // Calafiore et al. eqs. (10)–(11) with Metropolis weights (docs/algorithms.md §1.2); newest value per
  // neighbour (§6.4).
  const int own_degree = range_count_;
  double rho = rho_;
  double psi = psi_;
  double self_weight = 1.0;
  double rho_sum = 0.0;
  double psi_sum = 0.0;
  for (Peer& peer : peers_) {
    if (!peer.has_range) continue;
    const int degree = peer.degree > 0 ? peer.degree : own_degree;
    // The degrees rarely change, so the weight is recomputed only when they do.
    if (peer.weight_degree != degree) {
      peer.weight = consensus::metropolis_edge_weight(own_degree, degree, params_.weights);
      peer.weight_degree = degree;
    }
    const double w = peer.weight;
    self_weight -= w;
    rho_sum += w * (peer.have_consensus ? peer.rho : rho);
    psi_sum += w * (peer.have_consensus ? peer.psi : psi);
  }
  rho_ = self_weight * rho + rho_sum;
  psi_ = self_weight * psi + psi_sum;
}

void DgBb::absorb(const StepInput& input) {
  if (input.measurements != nullptr) {
    for (const RangeMeasurement& m : input.measurements->ranges) {
      if (m.peer == setup_.id || !std::isfinite(m.range_m)) continue;
      Peer& n = peers_[peer_index(m.peer)];
      if (!n.has_range) {
        n.has_range = true;
        ++range_count_;
        for (Peer& other : peers_) other.weight_degree = 0;  // every W_ij depends on the own degree
      }
      n.range = m.range_m;
    }
  }
  if (input.inbox == nullptr) return;
  const auto& states = input.inbox->states;
  state_hints_.resize(states.size(), 0);
  for (std::size_t k = 0; k < states.size(); ++k) {
    const auto& received = states[k];
    Peer& n = inbox_peer(state_hints_[k], received.sender);
    if (!received.message.mean_m.allFinite()) continue;
    n.position = received.message.mean_m;
    n.degree = received.message.degree;
    n.have_state = true;
  }
  const auto& consensus_values = input.inbox->consensus;
  consensus_hints_.resize(consensus_values.size(), 0);
  for (std::size_t k = 0; k < consensus_values.size(); ++k) {
    const auto& received = consensus_values[k];
    if (received.message.values.size() < 2) continue;
    Peer& n = inbox_peer(consensus_hints_[k], received.sender);
    n.rho = received.message.values[0];
    n.psi = received.message.values[1];
    n.have_consensus = true;
  }
}

double DgBb::local_step(const Vec2& D) {
  double alpha = params_.fixed_step;
  if (params_.rule == StepRule::kConsensusBb || params_.rule == StepRule::kLocalBb) {
    const Vec2 dp = p_ - p_prev_;
    Vec2 D_before_own_move = D_prev_;
    // The neighbours where they are now (all of them are known once the node has started).
    if (params_.rule == StepRule::kLocalBb && params_.own_move_curvature &&
        !direction_at(p_prev_, D_before_own_move)) {
      D_before_own_move = D_prev_;
    }
    const Vec2 dD = D - D_before_own_move;
    const double rho = dp.squaredNorm();
    const double psi = dp.dot(dD);
    alpha = rho / psi;  // Calafiore et al. eq. (15)
    if (params_.curvature_safeguard && !bb_step_valid(rho, psi, alpha)) {
      alpha = have_valid_alpha_ ? last_valid_alpha_ : params_.warmup_step;  // [E-4]
      if (active_) ++safeguard_count_;
    } else if (bb_step_valid(rho, psi, alpha)) {
      last_valid_alpha_ = alpha;
      have_valid_alpha_ = true;
    }
    alpha = capped_bb_step(alpha, D);
  } else if (params_.rule == StepRule::kStepLength) {
    const double tau = static_cast<double>(std::max<std::int64_t>(tau_, 1));
    double k = params_.step_length;
    if (params_.schedule == StepLengthSchedule::kOverTau) k /= tau;
    if (params_.schedule == StepLengthSchedule::kOverSqrtTau) k /= std::sqrt(tau);
    const double norm = D.norm();
    alpha = norm > 0.0 ? k / norm : 0.0;
  }
  return alpha;
}

void DgBb::consensus_step(StepOutput& out) {
  if (round_ == 0) {  // Calafiore et al. eqs. (8)–(9)
    Vec2 D;
    if (!direction(D)) D = D_prev_;
    D_cur_ = D;
    const Vec2 dp = p_ - p_prev_;
    rho_ = dp.squaredNorm();
    psi_ = dp.dot(D_cur_ - D_prev_);
    publish(out.outbox, true);
    round_ = 1;
    return;
  }
  consensus_round();
  if (round_ < params_.consensus_rounds) {
    publish(out.outbox, true);
    ++round_;
    return;
  }
  // Round T: α_i = ρ_i(T)/ψ_i(T) (Calafiore et al. eq. (12)) with the [E-4] safeguard, then eq. (14).
  double alpha = rho_ / psi_;
  if (!bb_step_valid(rho_, psi_, alpha)) {
    if (params_.curvature_safeguard) {
      alpha = have_valid_alpha_ ? last_valid_alpha_ : params_.warmup_step;
      if (active_) ++safeguard_count_;
    }
  } else {
    last_valid_alpha_ = alpha;
    have_valid_alpha_ = true;
  }
  alpha = capped_bb_step(alpha, D_cur_);
  if (active_) last_alpha_ = alpha;
  apply_update(D_cur_, alpha);
  out.diagnostics.updated = true;
  round_ = 0;
  publish(out.outbox, false);
}

StepOutput DgBb::step(const StepInput& input) {
  StepOutput out;
  absorb(input);
  out.diagnostics.neighbours_used = range_count_;
  if (tau_ >= params_.max_updates || range_count_ == 0) {
    publish(out.outbox, false);
    return out;
  }

  Vec2 D;
  if (phase_ == Phase::kWaiting) {  // §6.4: start only once every neighbour has been heard from
    if (!direction(D)) {
      publish(out.outbox, false);
      return out;
    }
    phase_ = params_.warmup_updates > 0 ? Phase::kWarmup : Phase::kRound;
    round_ = 0;
  }

  if (phase_ == Phase::kWarmup) {  // docs/algorithms.md §6.2 step 1
    direction(D);
    apply_update(D, params_.warmup_step);
    out.diagnostics.updated = true;
    if (tau_ >= params_.warmup_updates) phase_ = Phase::kRound;
    publish(out.outbox, false);
    return out;
  }

  if (params_.rule == StepRule::kConsensusBb && params_.consensus_rounds > 0) {
    consensus_step(out);
    return out;
  }
  // Baselines (and DG-BB with T = 0 = local BB): one STATE exchange per update (§6.5).
  if (!direction(D)) D = Vec2::Zero();
  const double alpha = local_step(D);
  if (active_) last_alpha_ = alpha;
  apply_update(D, alpha);
  out.diagnostics.updated = true;
  publish(out.outbox, false);
  return out;
}

Estimate DgBb::estimate() const {
  Estimate estimate;
  estimate.mean_m = p_;
  estimate.covariance = Mat2::Zero();  // a point estimate: no covariance is computed
  estimate.valid = setup_.anchor || tau_ > 0;
  return estimate;
}

// ---- Centralized reference ----
std::vector<Vec2> direction(const RangeProblem& problem, const std::vector<Vec2>& p, double grad_scale) {
  std::vector<Vec2> D(p.size(), Vec2::Zero());
  for (const RangeEdge& e : problem.edges) {
    const auto i = static_cast<std::size_t>(e.i);
    const auto j = static_cast<std::size_t>(e.j);
    const Vec2 delta = p[i] - p[j];
    const double g = delta.squaredNorm() - e.range_m * e.range_m;
    D[i] += g * delta;
    D[j] -= g * delta;
  }
  for (std::size_t i = 0; i < p.size(); ++i)
    D[i] = problem.anchor[i] ? Vec2::Zero() : Vec2(grad_scale * D[i]);
  return D;
}

double objective(const RangeProblem& problem, const std::vector<Vec2>& p) {
  double f = 0.0;
  for (const RangeEdge& e : problem.edges) {
    const double g = (p[static_cast<std::size_t>(e.i)] - p[static_cast<std::size_t>(e.j)]).squaredNorm() -
                     e.range_m * e.range_m;
    f += 0.5 * g * g;
  }
  return f;
}

double centralized_bb_step(const std::vector<Vec2>& dp, const std::vector<Vec2>& dD) {
  double rho = 0.0;
  double psi = 0.0;
  for (std::size_t i = 0; i < dp.size(); ++i) {
    rho += dp[i].squaredNorm();
    psi += dp[i].dot(dD[i]);
  }
  return rho / psi;  // Calafiore et al. eq. (5)
}

CentralizedBbResult centralized_bb(const RangeProblem& problem, const DgBbParams& params) {
  validate(params);
  const std::size_t n = problem.initial.size();
  std::vector<Vec2> p = problem.initial;
  std::vector<Vec2> p_prev(n, Vec2::Zero());
  std::vector<Vec2> D_prev(n, Vec2::Zero());
  std::vector<bool> active(n);
  for (std::size_t i = 0; i < n; ++i) active[i] = !problem.anchor[i];
  CentralizedBbResult result;
  double last_valid = params.warmup_step;
  auto any_active = [&] {
    for (const bool a : active) {
      if (a) return true;
    }
    return false;
  };
  while (result.updates < params.max_updates && any_active()) {
    const std::vector<Vec2> D = direction(problem, p, params.grad_scale);
    double alpha = params.warmup_step;
    if (result.updates >= params.warmup_updates) {
      std::vector<Vec2> dp(n);
      std::vector<Vec2> dD(n);
      for (std::size_t i = 0; i < n; ++i) {
        dp[i] = p[i] - p_prev[i];
        dD[i] = D[i] - D_prev[i];
      }
      alpha = centralized_bb_step(dp, dD);
      if (!(std::isfinite(alpha) && alpha > 0.0)) {
        if (params.curvature_safeguard) alpha = last_valid;  // [E-4]
      } else {
        last_valid = alpha;
      }
      alpha = std::min(alpha, params.max_step);
      result.steps.push_back(alpha);
    }
    for (std::size_t i = 0; i < n; ++i) {
      p_prev[i] = p[i];
      if (!active[i]) continue;
      const Vec2 next = p[i] - alpha * D[i];
      if (!((next - p[i]).norm() > params.abs_tol)) active[i] = false;
      p[i] = next;
    }
    D_prev = D;
    ++result.updates;
  }
  result.positions = std::move(p);
  return result;
}

}  // namespace swarmloc::estimators::gradient
