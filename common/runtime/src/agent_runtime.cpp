#include "swarmloc/runtime/agent_runtime.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>

#include "swarmloc/core/gaussian.hpp"

namespace swarmloc::runtime {

AgentRuntime::AgentRuntime(std::unique_ptr<estimators::Estimator> estimator, estimators::AgentSetup setup,
                           std::vector<AgentId> neighbours, const AgentRuntimeParams& params)
    : estimator_(std::move(estimator)),
      setup_(std::move(setup)),
      neighbours_(std::move(neighbours)),
      params_(params),
      loss_(params.seed, params.loss),
      next_seq_(params.first_seq) {
  std::sort(neighbours_.begin(), neighbours_.end());
  neighbours_.erase(std::unique(neighbours_.begin(), neighbours_.end()), neighbours_.end());
  links_.resize(neighbours_.size());
  link_seen_.assign(neighbours_.size(), false);
  sent_by_earlier_incarnations_.assign(neighbours_.size(), 0);
  init_mailbox(states_);
  init_mailbox(information_);
  init_mailbox(consensus_);
  init_mailbox(beliefs_);
  init_mailbox(observations_);
}

int AgentRuntime::slot_of(AgentId id) const {
  const auto it = std::lower_bound(neighbours_.begin(), neighbours_.end(), id);
  return it != neighbours_.end() && *it == id ? static_cast<int>(it - neighbours_.begin()) : -1;
}

template <typename Message>
void AgentRuntime::init_mailbox(Mailbox<Message>& mailbox) const {
  mailbox.newest_seq.assign(neighbours_.size(), 0);
  mailbox.index.assign(neighbours_.size(), -1);
}

bool AgentRuntime::partitioned(const Header& header) const {
  const auto& group = params_.partition_group;
  if (group.empty() || !(params_.world_period_s > 0.0)) return false;
  const auto world_step = static_cast<std::int64_t>(
      std::llround(static_cast<double>(header.world_stamp_ns) * 1e-9 / params_.world_period_s));
  if (world_step < params_.partition_from || world_step > params_.partition_to) return false;
  const auto a = static_cast<std::size_t>(header.agent_id);
  const auto b = static_cast<std::size_t>(setup_.id);
  return a < group.size() && b < group.size() && group[a] != group[b];
}

namespace {

// Inter-agent vectors are small (a 2-D position, a target state, a few consensus scalars); anything
// longer is a broken or hostile sample.
constexpr std::size_t kMaxVectorLength = 64;
// Consensus scalars (ρ, ψ of DG-BB: squared step lengths and curvatures) stay far below this.
constexpr double kAbsurdScalar = 1e30;
/// Belief.contributions' IDL bound (exact GaBP: one per neighbour).
constexpr std::size_t kMaxBeliefContributions = 1024;
/// State.edge_ranges' IDL bound (dml sends a few per sample).
constexpr std::size_t kMaxEdgeRanges = 16;
/// Observations' IDL bounds (team_pose_ekf: its newest spans of its own data).
constexpr std::size_t kMaxObservedSpans = 64;
constexpr std::size_t kMaxSpanOdometrySegments = 1024;
constexpr std::size_t kMaxSpanRangeBearings = 256;

bool finite_odometry(const estimators::OdometryInput& odometry) {
  if (!std::isfinite(odometry.v_std) || !std::isfinite(odometry.omega_std)) return false;
  return std::all_of(odometry.segments.begin(), odometry.segments.end(), [](const auto& segment) {
    return std::isfinite(segment.v_mps) && std::isfinite(segment.omega_radps) && std::isfinite(segment.dt_s);
  });
}

bool finite_range_bearing(const estimators::RangeBearingMeasurement& m) {
  return std::isfinite(m.range_m) && std::isfinite(m.bearing_rad) && std::isfinite(m.range_std_m) &&
         std::isfinite(m.age_s) && std::isfinite(m.bearing_std_rad) && m.landmark_m.allFinite() &&
         m.landmark_cov.allFinite();
}

/// Spans oldest first, each starting right after the one before, the first right after the origin.
bool well_ordered(const estimators::ObservationMessage& m) {
  std::int64_t previous = m.origin_step;
  for (const auto& span : m.spans) {
    if (span.first_world_step != previous + 1 || span.world_step < span.first_world_step) return false;
    previous = span.world_step;
  }
  return true;
}

}  // namespace

std::optional<RejectReason> AgentRuntime::check_content(const estimators::StateMessage& m) const {
  if (!m.mean_m.allFinite() || !m.covariance.allFinite()) return RejectReason::kNonFinite;
  if (m.mean_m.norm() > params_.absurd_position_bound_m ||
      m.covariance.cwiseAbs().maxCoeff() > params_.absurd_variance_m2) {
    return RejectReason::kAbsurdMagnitude;
  }
  if (!core::is_symmetric_psd(m.covariance, 1e-9)) return RejectReason::kNotSymmetricPsd;
  if (const auto& z = m.altitude) {  // 3-D: the same rules for the (x, y, z) position and covariance
    if (!std::isfinite(z->z_m) || !std::isfinite(z->variance_m2) || !z->cross_m2.allFinite())
      return RejectReason::kNonFinite;
    if (join(m.mean_m, z->z_m).norm() > params_.absurd_position_bound_m ||
        std::max(std::abs(z->variance_m2), z->cross_m2.cwiseAbs().maxCoeff()) > params_.absurd_variance_m2) {
      return RejectReason::kAbsurdMagnitude;
    }
    if (z->variance_m2 < 0.0 || !core::is_symmetric_psd_dynamic(MatX(join(m.covariance, *z)), 1e-9))
      return RejectReason::kNotSymmetricPsd;
  }
  if (m.edge_ranges.size() > kMaxEdgeRanges) return RejectReason::kAbsurdMagnitude;
  for (const auto& edge : m.edge_ranges) {
    if (!std::isfinite(edge.information) || !std::isfinite(edge.mean_range_m) ||
        !edge.peer_mean_m.allFinite() || !std::isfinite(edge.peer_z_m))
      return RejectReason::kNonFinite;
    // peer_z_m is 0 in planar worlds: the norm is the planar one there, to the bit.
    if (edge.information < 0.0 || edge.information > kAbsurdScalar || edge.mean_range_m < 0.0 ||
        edge.mean_range_m > 2.0 * params_.absurd_position_bound_m ||
        join(edge.peer_mean_m, edge.peer_z_m).norm() > params_.absurd_position_bound_m) {
      return RejectReason::kAbsurdMagnitude;
    }
  }
  if (m.cavities.size() > estimators::StateMessage::kMaxCavities) return RejectReason::kAbsurdMagnitude;
  for (const auto& cavity : m.cavities) {
    if (!cavity.offset_m.allFinite() || !std::isfinite(cavity.offset_z_m) ||
        !std::isfinite(cavity.variance_m2))
      return RejectReason::kNonFinite;
    // offset_z_m is 0 in planar worlds: the norm is the planar one there, to the bit.
    if (cavity.variance_m2 < 0.0 || cavity.variance_m2 > params_.absurd_variance_m2 ||
        join(cavity.offset_m, cavity.offset_z_m).norm() > params_.absurd_position_bound_m) {
      return RejectReason::kAbsurdMagnitude;
    }
  }
  return std::nullopt;
}

std::optional<RejectReason> AgentRuntime::check_content(const estimators::InformationMessage& m) const {
  const auto n = m.info_vec.size();
  if (static_cast<std::size_t>(n) > kMaxVectorLength || m.info_mat.rows() != n || m.info_mat.cols() != n ||
      m.world_step < -1) {
    return RejectReason::kMalformed;
  }
  if (!m.info_vec.allFinite() || !m.info_mat.allFinite()) return RejectReason::kNonFinite;
  if (n > 0 && (m.info_vec.cwiseAbs().maxCoeff() > kAbsurdScalar ||
                m.info_mat.cwiseAbs().maxCoeff() > kAbsurdScalar)) {
    return RejectReason::kAbsurdMagnitude;
  }
  if (!core::is_symmetric_psd_dynamic(m.info_mat, 1e-9)) return RejectReason::kNotSymmetricPsd;
  return std::nullopt;
}

std::optional<RejectReason> AgentRuntime::check_content(const estimators::ConsensusMessage& m) const {
  if (m.values.size() > kMaxVectorLength || m.tau < 0 || m.round < 0) return RejectReason::kMalformed;
  for (const double v : m.values) {
    if (!std::isfinite(v)) return RejectReason::kNonFinite;
    if (std::abs(v) > kAbsurdScalar) return RejectReason::kAbsurdMagnitude;
  }
  return std::nullopt;
}

std::optional<RejectReason> AgentRuntime::check_content(const estimators::ObservationMessage& m) const {
  if (m.origin_step < -1 || m.spans.size() > kMaxObservedSpans || !well_ordered(m))
    return RejectReason::kMalformed;
  for (const auto& span : m.spans) {
    if (span.range_bearings.size() > kMaxSpanRangeBearings ||
        (span.odometry && span.odometry->segments.size() > kMaxSpanOdometrySegments)) {
      return RejectReason::kMalformed;
    }
    if (!std::isfinite(span.world_time_s) || (span.odometry && !finite_odometry(*span.odometry)) ||
        !std::all_of(span.range_bearings.begin(), span.range_bearings.end(), finite_range_bearing)) {
      return RejectReason::kNonFinite;
    }
  }
  if (!m.origin_pose.allFinite() || !m.origin_covariance.allFinite()) return RejectReason::kNonFinite;
  if (m.origin_pose.head<2>().norm() > params_.absurd_position_bound_m ||
      m.origin_covariance.cwiseAbs().maxCoeff() > params_.absurd_variance_m2) {
    return RejectReason::kAbsurdMagnitude;
  }
  if (!core::is_symmetric_psd_dynamic(m.origin_covariance, 1e-9)) return RejectReason::kNotSymmetricPsd;
  return std::nullopt;
}

std::optional<RejectReason> AgentRuntime::check_content(const estimators::BeliefMessage& m) const {
  if (m.iteration < 0) return RejectReason::kMalformed;
  if (!m.mean_m.allFinite() || !m.information.allFinite()) return RejectReason::kNonFinite;
  if (m.mean_m.norm() > params_.absurd_position_bound_m ||
      m.information.cwiseAbs().maxCoeff() > kAbsurdScalar) {
    return RejectReason::kAbsurdMagnitude;
  }
  if (!core::is_symmetric_psd(m.information, 1e-9)) return RejectReason::kNotSymmetricPsd;
  // Exact GaBP's contributions: at most one per neighbour, each a message with PSD information.
  if (m.contributions.size() > kMaxBeliefContributions) return RejectReason::kMalformed;
  std::vector<AgentId> senders;
  senders.reserve(m.contributions.size());
  for (const auto& c : m.contributions) {
    if (c.from < 0) return RejectReason::kMalformed;
    if (!c.information.allFinite() || !c.info_vec.allFinite()) return RejectReason::kNonFinite;
    if (c.information.cwiseAbs().maxCoeff() > kAbsurdScalar ||
        c.info_vec.cwiseAbs().maxCoeff() > kAbsurdScalar)
      return RejectReason::kAbsurdMagnitude;
    if (!core::is_symmetric_psd(c.information, 1e-9)) return RejectReason::kNotSymmetricPsd;
    senders.push_back(c.from);
  }
  std::sort(senders.begin(), senders.end());
  if (std::adjacent_find(senders.begin(), senders.end()) != senders.end()) return RejectReason::kMalformed;
  return std::nullopt;
}

void AgentRuntime::reject(LinkCounters* link, RejectReason reason) {
  ++rejected_by_reason_[static_cast<std::size_t>(reason)];
  if (link != nullptr) ++link->rejected;
}

std::int64_t AgentRuntime::world_stamp_ns(std::int64_t world_step) const {
  return world_step < 0 ? 0
                        : static_cast<std::int64_t>(
                              std::llround(static_cast<double>(world_step) * batch_period_s_ * 1e9));
}

template <typename Message>
estimators::Received<Message>* AgentRuntime::on_sample(core::TopicFamily family, Mailbox<Message>& mailbox,
                                                       std::vector<estimators::Received<Message>>& newest,
                                                       const Header& header, const Message& message,
                                                       bool well_formed) {
  if (header.agent_id == setup_.id) return nullptr;  // own sample (should not be routed here)
  const int slot = slot_of(header.agent_id);
  const auto at = static_cast<std::size_t>(slot);
  LinkCounters* link = nullptr;
  if (slot >= 0) {
    link = &links_[at];
    if (!link_seen_[at]) {
      link_seen_[at] = true;
      link->sender = header.agent_id;
      link->first_seq = header.seq;
      link->last_seq = header.seq;
    }
    ++link->arrived;
    if ((header.seq >> 24) != (link->last_seq >> 24)) {
      // The sender restarted (faults.kill) and numbers from a new range: bank the old range.
      sent_by_earlier_incarnations_[at] += link->last_seq - link->first_seq + 1;
      link->first_seq = header.seq;
      link->last_seq = header.seq;
    }
    link->first_seq = std::min(link->first_seq, header.seq);
    link->last_seq = std::max(link->last_seq, header.seq);
    if (loss_.drops(header.agent_id, setup_.id, family, header.seq) || partitioned(header)) {
      ++link->dropped_injected;
      return nullptr;
    }
  }
  std::optional<RejectReason> reason;
  if (!well_formed) {
    reason = RejectReason::kMalformed;
  } else if (link == nullptr) {
    reason = RejectReason::kUnknownSender;
  } else {
    reason = check_content(message);
  }
  if (!reason && mailbox.index[at] >= 0) {
    if (header.seq == mailbox.newest_seq[at]) reason = RejectReason::kDuplicate;
    if (header.seq < mailbox.newest_seq[at]) reason = RejectReason::kReordered;
  }
  if (reason) {
    reject(link, *reason);
    return nullptr;
  }
  ++link->delivered;
  if (header.step >= 0) ++link->delivered_in_steps;
  mailbox.newest_seq[at] = header.seq;
  if (mailbox.index[at] < 0) {
    // The neighbour's first sample: its place among the others, in slot order.
    mailbox.index[at] = 0;
    int next = 0;
    for (int& index : mailbox.index) {
      if (index >= 0) index = next++;
    }
    newest.insert(newest.begin() + mailbox.index[at], estimators::Received<Message>{});
  }
  auto& stored = newest[static_cast<std::size_t>(mailbox.index[at])];
  stored.sender = header.agent_id;
  stored.sender_step = local_step_ - 1;  // in the receiver's frame: as if sent at its previous step
  stored.message = message;
  return &stored;
}

bool AgentRuntime::on_state(const Header& header, const estimators::StateMessage& message, bool well_formed) {
  auto* stored = on_sample(core::TopicFamily::kState, states_, inbox_.states, header, message, well_formed);
  if (stored != nullptr) stored->message.covariance = core::symmetrized(stored->message.covariance);
  return stored != nullptr;
}

bool AgentRuntime::on_information(const Header& header, const estimators::InformationMessage& message,
                                  bool well_formed) {
  auto* stored = on_sample(core::TopicFamily::kInformation, information_, inbox_.information, header, message,
                           well_formed);
  if (stored != nullptr) {
    auto& info = stored->message.info_mat;
    info = 0.5 * (info + info.transpose()).eval();
  }
  return stored != nullptr;
}

bool AgentRuntime::on_consensus(const Header& header, const estimators::ConsensusMessage& message,
                                bool well_formed) {
  return on_sample(core::TopicFamily::kConsensus, consensus_, inbox_.consensus, header, message,
                   well_formed) != nullptr;
}

bool AgentRuntime::on_observations(const Header& header, const estimators::ObservationMessage& message,
                                   bool well_formed) {
  auto* stored = on_sample(core::TopicFamily::kObservations, observations_, inbox_.observations, header,
                           message, well_formed);
  if (stored != nullptr) {
    auto& covariance = stored->message.origin_covariance;
    covariance = 0.5 * (covariance + covariance.transpose()).eval();
  }
  return stored != nullptr;
}

bool AgentRuntime::on_belief(const Header& header, const estimators::BeliefMessage& message,
                             bool well_formed) {
  auto* stored =
      on_sample(core::TopicFamily::kBelief, beliefs_, inbox_.beliefs, header, message, well_formed);
  if (stored != nullptr) stored->message.information = core::symmetrized(stored->message.information);
  return stored != nullptr;
}

namespace {

/// What sanitize_batch needs of the runtime: its sorted neighbour ids and limits. Rejections are
/// collected in order and counted by the runtime afterwards (no callback per measurement).
struct BatchChecks {
  const std::vector<AgentId>& neighbours;
  double absurd = 0.0;           ///< position bound, m
  double absurd_variance = 0.0;  ///< covariance entry bound, m²
  std::vector<RejectReason> rejected{};
  [[nodiscard]] bool is_neighbour(AgentId id) const {
    return std::binary_search(neighbours.begin(), neighbours.end(), id);
  }
  void count(RejectReason reason) { rejected.push_back(reason); }
  bool drop(RejectReason reason) {
    count(reason);
    return true;
  }
};

void sanitize_ranges(std::vector<estimators::RangeMeasurement>& ranges, BatchChecks& c) {
  std::set<AgentId> seen;
  std::erase_if(ranges, [&](const estimators::RangeMeasurement& range) {
    if (!c.is_neighbour(range.peer)) return c.drop(RejectReason::kUnknownSender);
    if (!std::isfinite(range.range_m) || !std::isfinite(range.std_m)) return c.drop(RejectReason::kNonFinite);
    if (range.range_m < 0.0 || range.std_m < 0.0 || range.range_m > 2.0 * c.absurd ||
        range.std_m > c.absurd) {
      return c.drop(RejectReason::kAbsurdMagnitude);
    }
    if (!seen.insert(range.peer).second) return c.drop(RejectReason::kDuplicate);
    return false;
  });
}

void sanitize_fix(std::optional<estimators::AbsoluteFix>& fix, BatchChecks& c) {
  if (!fix) return;
  if (!fix->position_m.allFinite() || !fix->covariance.allFinite()) {
    c.count(RejectReason::kNonFinite);
    fix.reset();
  } else if (fix->position_m.norm() > c.absurd || fix->covariance.cwiseAbs().maxCoeff() > c.absurd_variance) {
    c.count(RejectReason::kAbsurdMagnitude);
    fix.reset();
  } else if (!core::is_symmetric_psd(fix->covariance, 1e-9)) {
    c.count(RejectReason::kNotSymmetricPsd);
    fix.reset();
  }
}

void sanitize_motion(std::optional<estimators::MotionInput>& motion, BatchChecks& c) {
  if (!motion) return;
  if (!motion->velocity_mps.allFinite() || !std::isfinite(motion->dt_s) || !motion->process_cov.allFinite()) {
    c.count(RejectReason::kNonFinite);
    motion.reset();
  } else if ((motion->velocity_mps * motion->dt_s).norm() > c.absurd ||
             motion->process_cov.cwiseAbs().maxCoeff() > c.absurd_variance) {
    c.count(RejectReason::kAbsurdMagnitude);
    motion.reset();
  } else if (!core::is_symmetric_psd(motion->process_cov, 1e-9)) {
    c.count(RejectReason::kNotSymmetricPsd);
    motion.reset();
  }
}

/// Relative positions (jacobi): one per neighbour, finite, plausible, PSD covariance.
void sanitize_relative(std::vector<estimators::RelativeMeasurement>& relative, BatchChecks& c) {
  std::set<AgentId> seen;
  std::erase_if(relative, [&](const estimators::RelativeMeasurement& m) {
    if (!c.is_neighbour(m.peer)) return c.drop(RejectReason::kUnknownSender);
    if (!m.delta_m.allFinite() || !m.covariance.allFinite()) return c.drop(RejectReason::kNonFinite);
    if (m.delta_m.norm() > 2.0 * c.absurd || m.covariance.cwiseAbs().maxCoeff() > c.absurd_variance) {
      return c.drop(RejectReason::kAbsurdMagnitude);
    }
    if (!core::is_symmetric_psd(m.covariance, 1e-9) || m.covariance.determinant() <= 0.0) {
      return c.drop(RejectReason::kNotSymmetricPsd);
    }
    if (!seen.insert(m.peer).second) return c.drop(RejectReason::kDuplicate);
    return false;
  });
}

/// Multipath paths (multipath_bp): one per neighbour and path index (at most one per wall).
void sanitize_paths(std::vector<estimators::MultipathMeasurement>& paths, BatchChecks& c) {
  constexpr int kMaxPathsPerPeer = 32;
  std::set<std::pair<AgentId, int>> seen;
  std::erase_if(paths, [&](const estimators::MultipathMeasurement& m) {
    if (!c.is_neighbour(m.peer)) return c.drop(RejectReason::kUnknownSender);
    if (!std::isfinite(m.length_m) || !std::isfinite(m.aoa_here_rad) || !std::isfinite(m.aoa_there_rad)) {
      return c.drop(RejectReason::kNonFinite);
    }
    if (m.length_m > 4.0 * c.absurd || std::abs(m.aoa_here_rad) > 1e3 || std::abs(m.aoa_there_rad) > 1e3) {
      return c.drop(RejectReason::kAbsurdMagnitude);
    }
    if (m.path_index < 0 || m.path_index >= kMaxPathsPerPeer) return c.drop(RejectReason::kMalformed);
    if (!seen.insert({m.peer, m.path_index}).second) return c.drop(RejectReason::kDuplicate);
    return false;
  });
}

}  // namespace

void AgentRuntime::sanitize_batch(estimators::MeasurementBatch& batch) {
  BatchChecks checks{neighbours_, params_.absurd_position_bound_m, params_.absurd_variance_m2};
  sanitize_ranges(batch.ranges, checks);
  sanitize_fix(batch.fix, checks);
  sanitize_motion(batch.motion, checks);
  sanitize_relative(batch.relative, checks);
  sanitize_paths(batch.paths, checks);
  for (const RejectReason reason : checks.rejected) reject(nullptr, reason);
}

void AgentRuntime::carry_over(const estimators::MeasurementBatch& superseded,
                              estimators::MeasurementBatch& batch) {
  // Free run: a batch that arrived since the last step is superseded by this one before any step used
  // it. Its measurements are independent draws, so keep their information instead of losing it:
  // relative-position samples and target readings are appended (Jacobi averages every sample; the DLE
  // sums every reading's information, and counts a moving target's reading of one world step ago as
  // current, a lag of one period's motion), and each range is fused
  // with the newer range to the same peer by inverse-variance weighting (one range per peer, so a
  // Kalman update does not count the neighbour's position uncertainty twice).
  batch.relative.insert(batch.relative.begin(), superseded.relative.begin(), superseded.relative.end());
  batch.targets.insert(batch.targets.begin(), superseded.targets.begin(), superseded.targets.end());
  // Pose-state odometry: the superseded step's segments come first (the robot drove them first); its
  // sightings are kept, applied with the newer step's.
  if (superseded.odometry) {
    if (!batch.odometry)
      batch.odometry =
          estimators::OdometryInput{{}, superseded.odometry->v_std, superseded.odometry->omega_std};
    auto& segments = batch.odometry->segments;
    segments.insert(segments.begin(), superseded.odometry->segments.begin(),
                    superseded.odometry->segments.end());
  }
  // Their age counts to the end of the newer step.
  const double later_s = batch.world_time_s - superseded.world_time_s;
  const auto first_new = batch.range_bearings.size();
  batch.range_bearings.insert(batch.range_bearings.end(), superseded.range_bearings.begin(),
                              superseded.range_bearings.end());
  std::rotate(batch.range_bearings.begin(),
              batch.range_bearings.begin() + static_cast<std::ptrdiff_t>(first_new),
              batch.range_bearings.end());
  for (std::size_t k = 0; k < superseded.range_bearings.size(); ++k) {
    if (std::isfinite(later_s) && later_s > 0.0) batch.range_bearings[k].age_s += later_s;
  }
  for (auto& range : batch.ranges) {
    const auto old =
        std::find_if(superseded.ranges.begin(), superseded.ranges.end(),
                     [&](const estimators::RangeMeasurement& r) { return r.peer == range.peer; });
    if (old == superseded.ranges.end() || !(old->std_m > 0.0) || !(range.std_m > 0.0)) continue;
    const double w_old = 1.0 / (old->std_m * old->std_m);
    const double w_new = 1.0 / (range.std_m * range.std_m);
    range.range_m = (w_old * old->range_m + w_new * range.range_m) / (w_old + w_new);
    range.std_m = 1.0 / std::sqrt(w_old + w_new);
  }
}

void AgentRuntime::on_batch(const Header& header, estimators::MeasurementBatch batch) {
  (void)header;
  if (batch.world_step <= newest_batch_step_) return;  // late or duplicate batch
  sanitize_batch(batch);
  if (pending_batch_) carry_over(*pending_batch_, batch);
  newest_batch_step_ = batch.world_step;
  if (batch.world_step > 0) batch_period_s_ = batch.world_time_s / static_cast<double>(batch.world_step);
  pending_batch_ = std::move(batch);
}

AgentRuntime::Publication AgentRuntime::publish(estimators::Outbox outbox, std::int64_t step,
                                                std::int64_t sender_stamp_ns, std::int64_t world_stamp_ns) {
  Publication publication;
  publication.outbox = std::move(outbox);
  publication.header = Header{setup_.id, next_seq_, step, sender_stamp_ns, world_stamp_ns};
  const auto& out = publication.outbox;
  const auto samples =
      static_cast<std::uint32_t>((out.state ? 1U : 0U) + (out.information ? 1U : 0U) + out.consensus.size() +
                                 (out.belief ? 1U : 0U) + (out.observations ? 1U : 0U));
  next_seq_ += samples;
  samples_published_ += samples;
  if (step >= 0) samples_published_in_steps_ += samples;
  return publication;
}

AgentRuntime::Publication AgentRuntime::initial_publication(std::int64_t sender_stamp_ns) {
  // Step −1: published before step 0, consumed by the neighbours' step 0.
  return publish(estimator_->initial_outbox(), local_step_ - 1, sender_stamp_ns, 0);
}

AgentRuntime::Publication AgentRuntime::step(std::int64_t sender_stamp_ns) {
  estimators::StepInput input;
  input.local_step = local_step_;
  input.inbox = &inbox_;
  input.measurements = pending_batch_ ? &*pending_batch_ : nullptr;
  auto output = estimator_->step(input);
  const std::int64_t world_step = pending_batch_ ? pending_batch_->world_step : newest_batch_step_;
  pending_batch_.reset();

  Publication publication =
      publish(std::move(output.outbox), local_step_, sender_stamp_ns, world_stamp_ns(world_step));
  ++local_step_;
  return publication;
}

std::map<AgentId, LinkCounters> AgentRuntime::links() const {
  std::map<AgentId, LinkCounters> out;
  for (std::size_t slot = 0; slot < neighbours_.size(); ++slot) {
    if (!link_seen_[slot]) continue;
    LinkCounters counters = links_[slot];
    if (const std::uint32_t banked = sent_by_earlier_incarnations_[slot]; banked > 0) {
      // Keep sent() = last − first + 1 meaning "all samples the sender wrote", across its restarts.
      const std::uint32_t sent = counters.sent() + banked;
      counters.first_seq = 0;
      counters.last_seq = sent - 1;
    }
    out.emplace(neighbours_[slot], counters);
  }
  return out;
}

EstimateReport AgentRuntime::report(std::int64_t sender_stamp_ns, double cpu_s) const {
  EstimateReport r;
  r.header = Header{setup_.id, static_cast<std::uint32_t>(local_step_), local_step_, sender_stamp_ns,
                    world_stamp_ns(newest_batch_step_)};
  r.estimate = estimator_->estimate();
  r.steps_run = static_cast<std::uint32_t>(local_step_);
  r.samples_published = samples_published_;
  r.samples_published_in_steps = samples_published_in_steps_;
  r.cpu_s = cpu_s;
  r.links.reserve(neighbours_.size());
  for (const auto& [sender, counters] : links()) r.links.push_back(counters);
  r.rejected_by_reason = rejected_by_reason_;
  return r;
}

}  // namespace swarmloc::runtime
