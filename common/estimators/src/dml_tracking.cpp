#include "swarmloc/estimators/dml_tracking.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "rank_one_message.hpp"
#include "swarmloc/core/gaussian.hpp"
#include "swarmloc/estimators/kalman_family.hpp"

namespace swarmloc::estimators {
namespace {

using rank_one::kCavityTolerance;
using rank_one::kShortestDistanceM;
using rank_one::message_scale;

Mat2 isotropic(double variance) { return variance * Mat2::Identity(); }

}  // namespace

DmlTracking::DmlTracking(const AgentSetup& setup, const KalmanFamilyParams& params)
    : setup_(setup),
      params_process_variance_m2_(params.process_noise_std_m * params.process_noise_std_m),
      prior_mean_(setup.initial_guess_m),
      mean_(setup.initial_guess_m) {
  if (!setup.initial_guess_m.allFinite())
    throw std::invalid_argument("dml_track: initial guess is not finite");
  // A beacon does not move; every other agent follows the random walk the filter is told of.
  process_variance_m2_ = setup.anchor ? 0.0 : params_process_variance_m2_;
  const double start_std = std::isfinite(setup.initial_guess_std_m) && setup.initial_guess_std_m > 0.0
                               ? setup.initial_guess_std_m
                               : params.initial_std_m;
  prior_information_ = isotropic(1.0 / (start_std * start_std));
  information_ = prior_information_;
}

bool DmlTracking::exact_anchor() const { return setup_.anchor && world_step_ >= 0 && !noisy_fix_; }

void DmlTracking::start_world_step(const MeasurementBatch& batch) {
  if (world_step_ >= 0) {
    // The finished step's belief, predicted over the steps that passed, is the new step's unary factor.
    const auto elapsed = static_cast<double>(batch.world_step - world_step_);
    const Mat2 covariance = information_.inverse() + isotropic(elapsed * process_variance_m2_);
    prior_information_ = core::symmetrized(covariance.inverse());
    prior_mean_ = mean_;
  }
  for (auto& [id, edge] : edges_) {
    edge.peer_draw_used = std::max(edge.peer_draw_used, edge.peer_draw_in_factor);
    edge.peer_draw_in_factor = -1;
    edge.incoming = RankOne{};  // a new factor: it has sent nothing yet
    edge.own_information = 0.0;
  }
  for (const auto& range : batch.ranges) {
    if (range.peer == setup_.id || !(range.std_m > 0.0) || !std::isfinite(range.range_m)) continue;
    Edge& edge = edges_[range.peer];
    edge.own_information = 1.0 / (range.std_m * range.std_m);
    edge.own_range_m = range.range_m;
  }
  world_step_ = batch.world_step;
  fix_information_ = Mat2::Zero();
  fix_information_vector_ = Vec2::Zero();
  if (batch.fix && positive_definite(batch.fix->covariance) && batch.fix->position_m.allFinite()) {
    fix_information_ = batch.fix->covariance.inverse();
    fix_information_vector_ = fix_information_ * batch.fix->position_m;
    noisy_fix_ = true;
  }
}

void DmlTracking::absorb_beliefs(const Inbox& inbox) {
  for (const auto& received : inbox.beliefs) {
    if (received.sender == setup_.id) continue;
    const BeliefMessage& message = received.message;
    Edge& edge = edges_[received.sender];
    edge.has_belief = message.infinite_information || positive_definite(message.information);
    if (!edge.has_belief) continue;
    edge.tag = message.iteration - 1;
    edge.mean_m = message.mean_m;
    edge.covariance = message.infinite_information ? Mat2::Zero() : Mat2(message.information.inverse());
    edge.peer_information = 0.0;
    for (const auto& draw : message.contributions) {
      const double information = draw.information.trace();
      if (draw.from != setup_.id || !(information > 0.0) || !std::isfinite(information)) continue;
      edge.peer_information = information;
      edge.peer_range_m = draw.info_vec.norm() / information;
    }
  }
}

DmlTracking::Factor DmlTracking::factor_of(Edge& edge) const {
  double information = edge.own_information;
  double weighted = edge.own_information * edge.own_range_m;
  edge.peer_draw_in_factor = -1;
  if (edge.has_belief && edge.peer_information > 0.0) {
    double peer_information = 0.0;
    if (edge.tag == world_step_) {
      peer_information = edge.peer_information;
    } else if (edge.tag < world_step_ && edge.tag > edge.peer_draw_used) {
      // A draw that arrived after its step ended: both ends have moved since, which widens it.
      const auto age = static_cast<double>(world_step_ - edge.tag);
      peer_information =
          1.0 / (1.0 / edge.peer_information + age * (process_variance_m2_ + params_process_variance_m2_));
    }
    if (peer_information > 0.0) {
      information += peer_information;
      weighted += peer_information * edge.peer_range_m;
      edge.peer_draw_in_factor = edge.tag;
    }
  }
  return Factor{information, information > 0.0 ? weighted / information : 0.0};
}

DmlTracking::RankOne DmlTracking::message_to_peer(const Edge& edge, const Vec2& a) const {
  // m_{f→j} as the neighbour computes it: from this agent's belief without m_{f→i}.
  const RankOne& in = edge.incoming;
  const Mat2 own_cavity = information_ - in.scale * in.direction * in.direction.transpose();
  if (!positive_definite(own_cavity)) return {};
  const Mat2 own_cavity_covariance = own_cavity.inverse();
  const Vec2 own_cavity_vector = information_ * mean_ - in.scale * in.mean * in.direction;
  return RankOne{message_scale(edge.factor.information, a.dot(own_cavity_covariance * a)),
                 a.dot(own_cavity_covariance * own_cavity_vector) - edge.factor.range_m, a};
}

DmlTracking::RankOne DmlTracking::message_to_self(Edge& edge) const {
  if (!edge.has_belief) return {};
  const Factor factor = factor_of(edge);
  edge.factor = factor;
  const Vec2 offset = mean_ - edge.mean_m;
  if (!(factor.information > 0.0) || offset.norm() < kShortestDistanceM) return {};
  const Vec2 a = offset.normalized();
  const bool exact = edge.covariance.isZero();
  const double q = exact ? 0.0 : a.dot(edge.covariance * a);
  const double m = a.dot(edge.mean_m);
  double far_variance = q;
  double far_mean = m;
  if (edge.tag == world_step_ && !exact) {
    // The neighbour's belief holds this factor's message to it: take it out (the cavity), so the
    // factor's data does not come back.
    const RankOne sent = message_to_peer(edge, a);
    const double remaining = 1.0 - sent.scale * q;
    if (!(remaining > kCavityTolerance)) return {};  // all the neighbour knows along a came from here
    far_variance = q / remaining;
    far_mean = far_variance * (m / q - sent.scale * sent.mean);
  } else if (!exact) {
    // A belief of an earlier step: predicted to this one (its factors are other steps' and stay in).
    far_variance +=
        static_cast<double>(std::max<std::int64_t>(0, world_step_ - edge.tag)) * params_process_variance_m2_;
  }
  const double scale = message_scale(factor.information, far_variance);
  return RankOne{scale, far_mean + factor.range_m, a};
}

void DmlTracking::update_belief() {
  Mat2 information = prior_information_ + fix_information_;
  Vec2 vector = prior_information_ * prior_mean_ + fix_information_vector_;
  std::vector<std::pair<Edge*, RankOne>> messages;
  for (auto& [id, edge] : edges_) {
    const RankOne message = message_to_self(edge);
    information += message.scale * message.direction * message.direction.transpose();
    vector += message.scale * message.mean * message.direction;
    messages.emplace_back(&edge, message);
  }
  for (auto& [edge, message] : messages) edge->incoming = message;
  information_ = core::symmetrized(information);
  mean_ = information_.ldlt().solve(vector);
}

StepOutput DmlTracking::step(const StepInput& input) {
  StepOutput out;
  if (input.measurements != nullptr && input.measurements->world_step > world_step_)
    start_world_step(*input.measurements);
  if (input.inbox != nullptr) absorb_beliefs(*input.inbox);
  if (world_step_ >= 0 && !exact_anchor()) {
    for (int iteration = 0; iteration < kLocalIterations; ++iteration) update_belief();
    out.diagnostics.updated = true;
  }
  if (exact_anchor()) mean_ = setup_.initial_guess_m;
  for (const auto& [id, edge] : edges_) {
    if (edge.incoming.scale > 0.0) ++out.diagnostics.neighbours_used;
  }
  out.outbox.belief = belief_message();
  return out;
}

BeliefMessage DmlTracking::belief_message() const {
  BeliefMessage message;
  message.iteration = world_step_ + 1;  // the world steps absorbed
  message.mean_m = mean_;
  message.infinite_information = exact_anchor();
  message.information = exact_anchor() ? Mat2::Zero() : information_;
  // This step's own draws, addressed to their peers, as a factor on x_self − x_peer along the edge:
  // information w·aaᵀ and vector w·r·a (the peer reads w = trace, r = |vector| / w).
  for (const auto& [id, edge] : edges_) {
    if (!(edge.own_information > 0.0)) continue;
    const Vec2 offset = mean_ - edge.mean_m;
    const Vec2 a = edge.has_belief && offset.norm() >= kShortestDistanceM ? Vec2(offset.normalized())
                                                                          : Vec2(Vec2::UnitX());
    message.contributions.push_back(
        {id, edge.own_information * a * a.transpose(), edge.own_information * edge.own_range_m * a});
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
  estimate.mean_m = mean_;
  if (exact_anchor()) {
    estimate.covariance = Mat2::Zero();
    estimate.valid = true;
  } else if (positive_definite(information_)) {
    estimate.covariance = core::symmetrized(information_.inverse());
    estimate.valid = world_step_ >= 0;
  }
  return estimate;
}

}  // namespace swarmloc::estimators
