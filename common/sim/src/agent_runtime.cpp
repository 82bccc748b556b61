#include "swarmloc/sim/agent_runtime.hpp"

#include <cmath>

#include "swarmloc/core/gaussian.hpp"

namespace swarmloc::sim {

AgentRuntime::AgentRuntime(std::unique_ptr<estimators::Estimator> estimator, estimators::AgentSetup setup,
                           std::vector<AgentId> neighbours, AgentRuntimeParams params)
    : estimator_(std::move(estimator)),
      setup_(setup),
      neighbours_(neighbours.begin(), neighbours.end()),
      params_(params),
      loss_(params.seed, params.loss) {}

std::optional<RejectReason> AgentRuntime::check_state(const Header& header, const estimators::StateMessage& m,
                                                      bool well_formed) const {
  if (!well_formed) return RejectReason::kMalformed;
  if (!neighbours_.contains(header.agent_id)) return RejectReason::kUnknownSender;
  if (!m.mean_m.allFinite() || !m.covariance.allFinite()) return RejectReason::kNonFinite;
  if (m.mean_m.norm() > params_.absurd_position_bound_m ||
      m.covariance.cwiseAbs().maxCoeff() > params_.absurd_variance_m2) {
    return RejectReason::kAbsurdMagnitude;
  }
  if (!core::is_symmetric_psd(m.covariance, 1e-9)) return RejectReason::kNotSymmetricPsd;
  const auto newest = newest_state_seq_.find(header.agent_id);
  if (newest != newest_state_seq_.end()) {
    if (header.seq == newest->second) return RejectReason::kDuplicate;
    if (header.seq < newest->second) return RejectReason::kReordered;
  }
  return std::nullopt;
}

void AgentRuntime::reject(LinkCounters* link, RejectReason reason) {
  ++rejected_by_reason_[static_cast<std::size_t>(reason)];
  if (link != nullptr) ++link->rejected;
}

std::int64_t AgentRuntime::world_stamp_ns(std::int64_t world_step) const {
  return world_step < 0 ? 0 : static_cast<std::int64_t>(std::llround(static_cast<double>(world_step) * batch_period_s_ * 1e9));
}

bool AgentRuntime::on_state(const Header& header, const estimators::StateMessage& message, bool well_formed) {
  if (header.agent_id == setup_.id) return false;  // own sample (should not be routed here)
  LinkCounters* link = nullptr;
  if (neighbours_.contains(header.agent_id)) {
    auto [it, inserted] = links_.try_emplace(header.agent_id);
    link = &it->second;
    if (inserted) {
      link->sender = header.agent_id;
      link->first_seq = header.seq;
      link->last_seq = header.seq;
    }
    ++link->arrived;
    link->first_seq = std::min(link->first_seq, header.seq);
    link->last_seq = std::max(link->last_seq, header.seq);
    if (loss_.drops(header.agent_id, setup_.id, core::TopicFamily::kState, header.seq)) {
      ++link->dropped_injected;
      return false;
    }
  }
  if (const auto reason = check_state(header, message, well_formed)) {
    reject(link, *reason);
    return false;
  }
  ++link->delivered;
  newest_state_seq_[header.agent_id] = header.seq;
  auto& slot = states_[header.agent_id];
  slot.sender = header.agent_id;
  slot.sender_step = local_step_ - 1;  // in the receiver's frame: as if sent at its previous step
  slot.message = message;
  slot.message.covariance = core::symmetrized(message.covariance);
  return true;
}

void AgentRuntime::sanitize_batch(estimators::MeasurementBatch& batch) {
  const double absurd = params_.absurd_position_bound_m;
  const auto count = [&](RejectReason reason) { reject(nullptr, reason); };
  const auto drop = [&](RejectReason reason) {
    count(reason);
    return true;
  };
  std::set<AgentId> seen;
  std::erase_if(batch.ranges, [&](const estimators::RangeMeasurement& range) {
    if (!neighbours_.contains(range.peer)) return drop(RejectReason::kUnknownSender);
    if (!std::isfinite(range.range_m) || !std::isfinite(range.std_m)) return drop(RejectReason::kNonFinite);
    if (range.range_m < 0.0 || range.std_m < 0.0 || range.range_m > 2.0 * absurd || range.std_m > absurd) {
      return drop(RejectReason::kAbsurdMagnitude);
    }
    if (!seen.insert(range.peer).second) return drop(RejectReason::kDuplicate);
    return false;
  });
  if (batch.fix) {
    const auto& fix = *batch.fix;
    if (!fix.position_m.allFinite() || !fix.covariance.allFinite()) {
      count(RejectReason::kNonFinite);
      batch.fix.reset();
    } else if (fix.position_m.norm() > absurd ||
               fix.covariance.cwiseAbs().maxCoeff() > params_.absurd_variance_m2) {
      count(RejectReason::kAbsurdMagnitude);
      batch.fix.reset();
    } else if (!core::is_symmetric_psd(fix.covariance, 1e-9)) {
      count(RejectReason::kNotSymmetricPsd);
      batch.fix.reset();
    }
  }
  if (batch.motion) {
    const auto& motion = *batch.motion;
    if (!motion.velocity_mps.allFinite() || !std::isfinite(motion.dt_s) || !motion.process_cov.allFinite()) {
      count(RejectReason::kNonFinite);
      batch.motion.reset();
    } else if ((motion.velocity_mps * motion.dt_s).norm() > absurd ||
               motion.process_cov.cwiseAbs().maxCoeff() > params_.absurd_variance_m2) {
      count(RejectReason::kAbsurdMagnitude);
      batch.motion.reset();
    } else if (!core::is_symmetric_psd(motion.process_cov, 1e-9)) {
      count(RejectReason::kNotSymmetricPsd);
      batch.motion.reset();
    }
  }
}

void AgentRuntime::on_batch(const Header& header, estimators::MeasurementBatch batch) {
  (void)header;
  if (batch.world_step <= newest_batch_step_) return;  // late or duplicate batch
  sanitize_batch(batch);
  newest_batch_step_ = batch.world_step;
  if (batch.world_step > 0) batch_period_s_ = batch.world_time_s / static_cast<double>(batch.world_step);
  pending_batch_ = std::move(batch);
}

AgentRuntime::Publication AgentRuntime::initial_publication(std::int64_t sender_stamp_ns) {
  Publication publication;
  publication.outbox = estimator_->initial_outbox();
  publication.header = Header{setup_.id, next_seq_++, local_step_, sender_stamp_ns, 0};
  ++samples_published_;
  return publication;
}

AgentRuntime::Publication AgentRuntime::step(std::int64_t sender_stamp_ns) {
  estimators::Inbox inbox;
  inbox.states.reserve(states_.size());
  for (const auto& [sender, received] : states_) inbox.states.push_back(received);
  estimators::StepInput input;
  input.local_step = local_step_;
  input.inbox = &inbox;
  input.measurements = pending_batch_ ? &*pending_batch_ : nullptr;
  auto output = estimator_->step(input);
  const std::int64_t world_step = pending_batch_ ? pending_batch_->world_step : newest_batch_step_;
  pending_batch_.reset();

  Publication publication;
  publication.outbox = std::move(output.outbox);
  publication.header = Header{setup_.id, next_seq_, local_step_, sender_stamp_ns, world_stamp_ns(world_step)};
  if (publication.outbox.state) {
    ++next_seq_;
    ++samples_published_;
  }
  ++local_step_;
  return publication;
}

EstimateReport AgentRuntime::report(std::int64_t sender_stamp_ns, double cpu_s) const {
  EstimateReport r;
  r.header = Header{setup_.id, static_cast<std::uint32_t>(local_step_), local_step_, sender_stamp_ns,
                    world_stamp_ns(newest_batch_step_)};
  r.estimate = estimator_->estimate();
  r.steps_run = static_cast<std::uint32_t>(local_step_);
  r.samples_published = samples_published_;
  r.cpu_s = cpu_s;
  r.links.reserve(links_.size());
  for (const auto& [sender, counters] : links_) r.links.push_back(counters);
  r.rejected_by_reason = rejected_by_reason_;
  return r;
}

}  // namespace swarmloc::sim
