#include "swarmloc/estimators/dml/tracking.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "dml/rank_one_message.hpp"
#include "swarmloc/core/gaussian.hpp"
#include "swarmloc/estimators/kalman/kernels.hpp"

namespace swarmloc::estimators {
namespace {

using rank_one::kCavityTolerance;
using rank_one::kShortestDistanceM;
using rank_one::message_scale;

Mat2 isotropic(double variance) { return variance * Mat2::Identity(); }

}  // namespace

DmlTracking::DmlTracking(const AgentSetup& setup, const KalmanFilterParams& params)
    : setup_(setup),
      params_process_variance_m2_(params.process_noise_std_m * params.process_noise_std_m),
      tail_mean_(setup.initial_guess_m) {
  if (!setup.initial_guess_m.allFinite())
    throw std::invalid_argument("dml_track: initial guess is not finite");
  // A beacon does not move; every other agent follows the random walk the filter is told of.
  process_variance_m2_ = setup.anchor ? 0.0 : params_process_variance_m2_;
  const double start_std = std::isfinite(setup.initial_guess_std_m) && setup.initial_guess_std_m > 0.0
                               ? setup.initial_guess_std_m
                               : params.initial_std_m;
  tail_information_ = isotropic(1.0 / (start_std * start_std));
}

bool DmlTracking::exact_anchor() const { return setup_.anchor && world_step_ >= 0 && !noisy_fix_; }

void DmlTracking::start_world_step(const MeasurementBatch& batch) {
  Slot slot;
  slot.world_step = batch.world_step;
  if (window_.empty()) {
    slot.predicted_mean_m = tail_mean_;
    slot.predicted_covariance = tail_information_.inverse();
  } else {
    // Until solved, the new step is the newest belief predicted (the point to linearize at).
    const Slot& newest = window_.back();
    const auto elapsed = static_cast<double>(batch.world_step - newest.world_step);
    slot.predicted_mean_m = newest.mean_m;
    slot.predicted_covariance = newest.covariance + isotropic(elapsed * process_variance_m2_);
  }
  slot.mean_m = slot.predicted_mean_m;
  slot.covariance = slot.predicted_covariance;
  slot.information = core::symmetrized(slot.covariance.inverse());
  for (const auto& range : batch.ranges) {
    if (range.peer == setup_.id || !(range.std_m > 0.0) || !std::isfinite(range.range_m)) continue;
    SlotEdge& edge = slot.edges[range.peer];
    edge.own_information = 1.0 / (range.std_m * range.std_m);
    edge.own_range_m = range.range_m;
  }
  if (batch.fix && positive_definite(batch.fix->covariance) && batch.fix->position_m.allFinite()) {
    slot.fix_information = batch.fix->covariance.inverse();
    slot.fix_information_vector = slot.fix_information * batch.fix->position_m;
    noisy_fix_ = true;
  }
  if (!setup_.anchor) check_ranges(batch, slot);
  world_step_ = batch.world_step;
  window_.push_back(std::move(slot));
  if (window_.size() > kWindowSteps) {
    // The oldest step leaves: the forward filter's prediction of the next one (its data and all before
    // it, the messages frozen) becomes the window's prior.
    window_.pop_front();
    tail_mean_ = window_.front().predicted_mean_m;
    tail_information_ = core::symmetrized(window_.front().predicted_covariance.inverse());
  }
}

void DmlTracking::check_ranges(const MeasurementBatch& batch, const Slot& slot) {
  for (const auto& range : batch.ranges) {
    const auto peer = peers_.find(range.peer);
    if (peer == peers_.end() || !peer->second.has_belief || !(range.std_m > 0.0)) continue;
    const PeerMarginal& newest = peer->second.window.at(peer->second.tag);
    const Vec2 offset = slot.predicted_mean_m - newest.mean_m;
    if (offset.norm() < kShortestDistanceM) continue;
    const Vec2 u = offset.normalized();
    const auto elapsed = static_cast<double>(std::max<std::int64_t>(0, batch.world_step - peer->second.tag));
    const double peer_variance =
        peer->second.exact ? 0.0 : u.dot(newest.covariance * u) + elapsed * params_process_variance_m2_;
    self_check_.add(range.range_m - offset.norm(),
                    range.std_m * range.std_m + u.dot(slot.predicted_covariance * u) + peer_variance);
  }
  self_check_.end_step();
}

void DmlTracking::absorb_beliefs(const Inbox& inbox) {
  for (const auto& received : inbox.beliefs) {
    if (received.sender == setup_.id) continue;
    const BeliefMessage& message = received.message;
    Peer& peer = peers_[received.sender];
    peer.window.clear();
    peer.exact = message.infinite_information;
    peer.has_belief = peer.exact || positive_definite(message.information);
    if (!peer.has_belief) continue;
    peer.tag = message.iteration - 1;
    peer.window[peer.tag] = {message.mean_m, peer.exact ? Mat2::Zero() : Mat2(message.information.inverse())};
    for (const auto& entry : message.contributions) {
      if (entry.from >= kWindowEntryBase) {  // an older step of the sender's window
        if (!peer.exact && positive_definite(entry.information))
          peer.window[peer.tag - (entry.from - kWindowEntryBase)] = {entry.info_vec,
                                                                     entry.information.inverse()};
        continue;
      }
      const double information = entry.information.trace();
      if (entry.from != setup_.id || !(information > 0.0) || !std::isfinite(information)) continue;
      // The sender's draw to this agent of its step `tag`: it joins that step's factor (replacing, not
      // adding to, an earlier copy of the same draw).
      const auto slot = std::find_if(window_.begin(), window_.end(),
                                     [&](const Slot& s) { return s.world_step == peer.tag; });
      if (slot == window_.end()) continue;
      SlotEdge& edge = slot->edges[received.sender];
      edge.peer_information = information;
      edge.peer_range_m = entry.info_vec.norm() / information;
    }
  }
}

DmlTracking::Factor DmlTracking::factor_of(const SlotEdge& edge) const {
  const double information = edge.own_information + edge.peer_information;
  const double weighted = edge.own_information * edge.own_range_m + edge.peer_information * edge.peer_range_m;
  return Factor{information, information > 0.0 ? weighted / information : 0.0};
}

double DmlTracking::scale_to_peer(const Slot& slot, const SlotEdge& edge, const Factor& factor,
                                  const Vec2& a) {
  // The scale of m_{f→j} as the neighbour computes it: from this agent's marginal of the step without
  // m_{f→i}.
  const RankOne& in = edge.incoming;
  const Mat2 own_cavity = slot.information - in.scale * in.direction * in.direction.transpose();
  if (!positive_definite(own_cavity)) return 0.0;
  return message_scale(factor.information, a.dot(own_cavity.inverse() * a));
}

DmlTracking::RankOne DmlTracking::message_to_self(const Slot& slot, const SlotEdge& edge,
                                                  const Peer& peer) const {
  const Factor factor = factor_of(edge);
  if (!peer.has_belief || !(factor.information > 0.0)) return {};
  // The neighbour's marginal of this step; a step after its newest is predicted from its newest; a
  // step before its window keeps the message it had.
  auto far = peer.window.find(peer.exact ? peer.tag : slot.world_step);
  const bool same_step = far != peer.window.end() && !peer.exact;
  double predicted_variance = 0.0;
  if (far == peer.window.end()) {
    if (slot.world_step < peer.tag) return edge.incoming;
    far = peer.window.find(peer.tag);
    if (far == peer.window.end()) return {};
    predicted_variance = static_cast<double>(slot.world_step - peer.tag) * params_process_variance_m2_;
  }
  const Vec2 offset = slot.mean_m - far->second.mean_m;
  if (offset.norm() < kShortestDistanceM) return {};
  const Vec2 a = offset.normalized();
  const double q = peer.exact ? 0.0 : a.dot(far->second.covariance * a);
  double far_variance = q + predicted_variance;
  if (same_step) {
    // The neighbour's marginal holds this factor's message to it: take its information out (the cavity),
    // so the factor's data is not counted twice. The mean stays the marginal's (docs/algorithms.md §9.8).
    const double remaining = 1.0 - scale_to_peer(slot, edge, factor, a) * q;
    if (!(remaining > kCavityTolerance)) return {};  // all the neighbour knows along a came from here
    far_variance = q / remaining;
  }
  return RankOne{message_scale(factor.information, far_variance), a.dot(far->second.mean_m) + factor.range_m,
                 a};
}

void DmlTracking::update_window() {
  // A beacon does not move: every range message of the window lands on the same position, where the
  // neighbour's own messages of every other step come back to it (the cavity takes out one step's). It
  // keeps to its fixes (docs/algorithms.md §9.8).
  if (setup_.anchor) {
    solve_chain();
    return;
  }
  // Every message from the current marginals first (the cavity needs the message each marginal holds).
  std::vector<std::vector<RankOne>> messages(window_.size());
  for (std::size_t t = 0; t < window_.size(); ++t) {
    for (auto& [id, edge] : window_[t].edges) {
      const auto peer = peers_.find(id);
      messages[t].push_back(peer == peers_.end() ? RankOne{}
                                                 : message_to_self(window_[t], edge, peer->second));
    }
  }
  for (std::size_t t = 0; t < window_.size(); ++t) {
    std::size_t k = 0;
    for (auto& [id, edge] : window_[t].edges) edge.incoming = messages[t][k++];
  }
  solve_chain();
}

void DmlTracking::solve_chain() {
  // Forward: the Kalman filter of the chain, each step's data the fix and the incoming range messages.
  std::vector<Vec2> filtered_mean(window_.size());
  std::vector<Mat2> filtered_covariance(window_.size());
  for (std::size_t t = 0; t < window_.size(); ++t) {
    Slot& slot = window_[t];
    if (t == 0) {
      slot.predicted_mean_m = tail_mean_;
      slot.predicted_covariance = core::symmetrized(tail_information_.inverse());
    } else {
      const auto elapsed = static_cast<double>(slot.world_step - window_[t - 1].world_step);
      slot.predicted_mean_m = filtered_mean[t - 1];
      slot.predicted_covariance = filtered_covariance[t - 1] + isotropic(elapsed * process_variance_m2_);
    }
    const Mat2 prior_information = slot.predicted_covariance.inverse();
    Mat2 information = prior_information + slot.fix_information;
    Vec2 vector = prior_information * slot.predicted_mean_m + slot.fix_information_vector;
    for (const auto& [id, edge] : slot.edges) {
      const RankOne& in = edge.incoming;
      information += in.scale * in.direction * in.direction.transpose();
      vector += in.scale * in.mean * in.direction;
    }
    filtered_covariance[t] = core::symmetrized(information.inverse());
    filtered_mean[t] = information.ldlt().solve(vector);
  }
  // Backward: the Rauch–Tung–Striebel smoother gives every step's marginal.
  for (std::size_t r = window_.size(); r-- > 0;) {
    Slot& slot = window_[r];
    if (r + 1 == window_.size()) {
      slot.mean_m = filtered_mean[r];
      slot.covariance = filtered_covariance[r];
    } else {
      const Slot& next = window_[r + 1];
      const Mat2 gain = filtered_covariance[r] * next.predicted_covariance.inverse();
      slot.mean_m = filtered_mean[r] + gain * (next.mean_m - next.predicted_mean_m);
      slot.covariance = core::symmetrized(
          filtered_covariance[r] + gain * (next.covariance - next.predicted_covariance) * gain.transpose());
    }
    slot.information = core::symmetrized(slot.covariance.inverse());
  }
}

StepOutput DmlTracking::step(const StepInput& input) {
  StepOutput out;
  if (input.measurements != nullptr && input.measurements->world_step > world_step_)
    start_world_step(*input.measurements);
  if (input.inbox != nullptr) absorb_beliefs(*input.inbox);
  if (world_step_ >= 0 && !exact_anchor()) {
    for (int iteration = 0; iteration < kLocalIterations; ++iteration) update_window();
    out.diagnostics.updated = true;
  }
  if (!window_.empty()) {
    for (const auto& [id, edge] : window_.back().edges) {
      if (edge.incoming.scale > 0.0) ++out.diagnostics.neighbours_used;
    }
  }
  out.outbox.belief = belief_message();
  return out;
}

BeliefMessage DmlTracking::belief_message() const {
  BeliefMessage message;
  message.iteration = world_step_ + 1;  // the world steps absorbed
  const Estimate newest = estimate();
  message.mean_m = newest.mean_m;
  message.infinite_information = exact_anchor();
  message.information = exact_anchor() || window_.empty()
                            ? Mat2(exact_anchor() ? Mat2::Zero() : tail_information_)
                            : window_.back().information;
  if (window_.empty()) return message;
  // The newest step's own draws, addressed to their peers, as a factor on x_self − x_peer along the edge:
  // information w·aaᵀ and vector w·r·a (the peer reads w = trace, r = |vector| / w).
  for (const auto& [id, edge] : window_.back().edges) {
    if (!(edge.own_information > 0.0)) continue;
    const auto peer = peers_.find(id);
    Vec2 a = Vec2::UnitX();
    if (peer != peers_.end() && peer->second.has_belief) {
      const Vec2 offset = newest.mean_m - peer->second.window.at(peer->second.tag).mean_m;
      if (offset.norm() >= kShortestDistanceM) a = offset.normalized();
    }
    message.contributions.push_back(
        {id, edge.own_information * a * a.transpose(), edge.own_information * edge.own_range_m * a});
  }
  if (exact_anchor()) return message;
  // The older window steps' marginals (the neighbours take their cavities out of them).
  for (std::size_t t = 0; t + 1 < window_.size(); ++t) {
    const auto age = static_cast<AgentId>(world_step_ - window_[t].world_step);
    message.contributions.push_back({kWindowEntryBase + age, window_[t].information, window_[t].mean_m});
  }
  return message;
}

Outbox DmlTracking::initial_outbox() const {
  Outbox outbox;
  outbox.belief = belief_message();
  return outbox;
}

Estimate DmlTracking::estimate() const {
  Estimate estimate;
  if (window_.empty()) {
    estimate.mean_m = tail_mean_;
    estimate.covariance = core::symmetrized(tail_information_.inverse());
    return estimate;
  }
  estimate.mean_m = exact_anchor() ? setup_.initial_guess_m : window_.back().mean_m;
  if (exact_anchor()) {
    estimate.covariance = Mat2::Zero();
  } else {
    estimate.covariance = window_.back().covariance;
  }
  estimate.valid = true;
  estimate.inconsistent = self_check_.inconsistent();
  return estimate;
}

}  // namespace swarmloc::estimators
