// TeamPoseEkf (estimators/pose/team_pose_ekf.hpp).
#include "swarmloc/estimators/pose/team_pose_ekf.hpp"

#include <algorithm>
#include <stdexcept>
#include <utility>
#include <vector>

#include "pose/internal.hpp"
#include "swarmloc/models/measurement_models.hpp"

namespace swarmloc::estimators {
namespace {

/// Spans further ahead of this robot's own newest step than this are not kept (a hostile or confused
/// sender must not grow the logs); free-run peers are a few steps ahead at most.
constexpr std::int64_t kTeamHorizonSteps = 10'000;

MeasurementBatch span_batch(const ObservedSteps& span) {
  MeasurementBatch batch;
  batch.world_step = span.world_step;
  batch.world_time_s = span.world_time_s;
  batch.odometry = span.odometry;
  batch.range_bearings = span.range_bearings;
  return batch;
}

bool has_member(const CentralizedPoseEkf& filter, AgentId id) {
  const auto& ids = filter.ids();
  return std::find(ids.begin(), ids.end(), id) != ids.end();
}

}  // namespace

TeamPoseEkf::TeamPoseEkf(const AgentSetup& setup, const KalmanFilterParams& params)
    : setup_(setup), params_(params), settled_({setup}, params), current_(settled_) {
  pose_internal::validate(setup, params, "team_pose_ekf");
  if (params.team_share_spans < 1 || params.team_share_spans > 64 || params.team_wait_steps < 0) {
    throw std::invalid_argument("team_pose_ekf: team_share_spans must be in [1, 64], team_wait_steps >= 0");
  }
  own_poses_.push_back(OwnPose{-1, settled_.pose(setup.id), settled_.pose_covariance(setup.id)});
}

Outbox TeamPoseEkf::initial_outbox() const {
  Outbox outbox;
  outbox.observations = observations();
  return outbox;
}

void TeamPoseEkf::record_own(const MeasurementBatch& batch) {
  if (batch.world_step <= newest_step_) return;
  ObservedSteps span;
  span.first_world_step = newest_step_ + 1;
  span.world_step = batch.world_step;
  span.world_time_s = batch.world_time_s;
  span.odometry = batch.odometry;
  span.range_bearings = batch.range_bearings;
  for (const AgentId id : batch.neighbours) {
    if (id != setup_.id) expected_.insert(id);
  }
  store(logs_[setup_.id], span);
  own_spans_.push_back(std::move(span));
  while (own_spans_.size() > static_cast<std::size_t>(params_.team_share_spans)) own_spans_.pop_front();
  newest_step_ = batch.world_step;
}

void TeamPoseEkf::store(Log& log, const ObservedSteps& span) const {
  if (span.first_world_step > span.world_step || span.world_step <= settled_step_ ||
      span.world_step > std::max<std::int64_t>(newest_step_, 0) + kTeamHorizonSteps) {
    return;
  }
  // Every sample repeats the sender's recent spans: most are known already, and copying them is the step's
  // main cost.
  if (log.contains(span.world_step)) return;
  log.emplace(span.world_step, LoggedSpan{span.first_world_step, span_batch(span)});
}

void TeamPoseEkf::absorb(AgentId sender, const ObservationMessage& message) {
  if (sender == setup_.id) return;
  if (has_member(settled_, sender)) {
    for (const ObservedSteps& span : message.spans) store(logs_[sender], span);
    return;
  }
  waiting_.insert_or_assign(sender, message);
  try_join(sender);
}

void TeamPoseEkf::try_join(AgentId sender) {
  const auto waiting = waiting_.find(sender);
  if (waiting == waiting_.end() || waiting->second.origin_step > settled_step_) return;
  const ObservationMessage& message = waiting->second;
  // Bring the sender's own estimate at its origin to the settled step through its spans (robot-robot
  // sightings cannot be used alone): a late joiner's best pose at the step it enters the joint filter.
  CentralizedPoseEkf alone({}, params_);
  alone.add_robot(sender, message.origin_pose, message.origin_covariance);
  std::int64_t at = message.origin_step;
  for (const ObservedSteps& span : message.spans) {
    if (span.world_step <= at || span.world_step > settled_step_) continue;
    for (; at + 1 < span.world_step; ++at) alone.step({nullptr});
    const MeasurementBatch batch = span_batch(span);
    alone.step({&batch});
    at = span.world_step;
  }
  for (; at < settled_step_; ++at) alone.step({nullptr});
  const Pose pose = alone.pose(sender);
  const Mat3 covariance = alone.pose_covariance(sender);
  if (settled_step_ < 0) {
    // Before the first step: rebuild in id order, the order the centralized filter keeps its robots in.
    std::vector<std::pair<AgentId, std::pair<Pose, Mat3>>> members;
    for (const AgentId id : settled_.ids())
      members.push_back({id, {settled_.pose(id), settled_.pose_covariance(id)}});
    members.push_back({sender, {pose, covariance}});
    std::sort(members.begin(), members.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    settled_ = CentralizedPoseEkf({}, params_);
    for (const auto& [id, prior] : members) settled_.add_robot(id, prior.first, prior.second);
  } else {
    settled_.add_robot(sender, pose, covariance);
  }
  Log& log = logs_[sender];
  for (const ObservedSteps& span : message.spans) store(log, span);
  waiting_.erase(waiting);
}

bool TeamPoseEkf::covers(AgentId id, std::int64_t world_step) const {
  const auto log = logs_.find(id);
  if (log == logs_.end()) return false;
  const auto span = log->second.lower_bound(world_step);
  return span != log->second.end() && span->second.first_world_step <= world_step;
}

bool TeamPoseEkf::complete(std::int64_t world_step) const {
  if (!waiting_.empty()) return false;
  for (const AgentId id : expected_) {
    if (!has_member(settled_, id)) return false;
  }
  return std::all_of(settled_.ids().begin(), settled_.ids().end(),
                     [&](AgentId id) { return covers(id, world_step); });
}

std::vector<const MeasurementBatch*> TeamPoseEkf::batches_at(const CentralizedPoseEkf& filter,
                                                             std::int64_t world_step) const {
  std::vector<const MeasurementBatch*> batches;
  batches.reserve(filter.ids().size());
  for (const AgentId id : filter.ids()) {
    const MeasurementBatch* batch = nullptr;
    if (const auto log = logs_.find(id); log != logs_.end()) {
      if (const auto span = log->second.find(world_step); span != log->second.end())
        batch = &span->second.batch;
    }
    batches.push_back(batch);
  }
  return batches;
}

void TeamPoseEkf::advance_settled() {
  while (settled_step_ < newest_step_) {
    const std::int64_t next = settled_step_ + 1;
    const bool overdue = newest_step_ - next >= params_.team_wait_steps;
    if (!overdue && !complete(next)) break;
    settled_.step(batches_at(settled_, next));
    settled_step_ = next;
    std::vector<AgentId> joinable;
    for (const auto& [id, message] : waiting_) {
      if (message.origin_step <= settled_step_) joinable.push_back(id);
    }
    for (const AgentId id : joinable) try_join(id);
  }
  prune_logs();
}

void TeamPoseEkf::prune_logs() {
  for (auto& [id, log] : logs_) log.erase(log.begin(), log.upper_bound(settled_step_));
}

bool TeamPoseEkf::has_span_at(AgentId id, std::int64_t world_step) const {
  const auto log = logs_.find(id);
  return log != logs_.end() && log->second.contains(world_step);
}

void TeamPoseEkf::bring_current() {
  current_ = settled_;
  for (std::int64_t step = settled_step_ + 1; step <= newest_step_; ++step) {
    // A sighting of a robot whose data of this step has not arrived would be linearized where that robot
    // was a step ago, as if known there: it waits for the settled filter.
    const auto unsettled = [&](const RangeBearingMeasurement& m) {
      return !m.landmark && !has_span_at(m.peer, step);
    };
    std::vector<const MeasurementBatch*> batches = batches_at(current_, step);
    std::vector<MeasurementBatch> pruned;
    pruned.reserve(batches.size());  // the pointers below stay valid
    for (const MeasurementBatch*& batch : batches) {
      if (batch == nullptr ||
          std::none_of(batch->range_bearings.begin(), batch->range_bearings.end(), unsettled)) {
        continue;
      }
      pruned.push_back(*batch);
      std::erase_if(pruned.back().range_bearings, unsettled);
      batch = &pruned.back();
    }
    current_.step(batches);
  }
}

StepOutput TeamPoseEkf::step(const StepInput& input) {
  const bool own_data = input.measurements != nullptr && input.measurements->world_step > newest_step_;
  if (own_data) record_own(*input.measurements);
  if (input.inbox != nullptr) {
    for (const auto& received : input.inbox->observations) absorb(received.sender, received.message);
  }
  advance_settled();
  bring_current();
  if (own_data) {
    own_poses_.push_back(
        OwnPose{newest_step_, current_.pose(setup_.id), current_.pose_covariance(setup_.id)});
    while (own_poses_.size() > own_spans_.size() + 1) own_poses_.pop_front();
  }
  StepOutput out;
  out.outbox.observations = observations();
  out.diagnostics = current_.last_diagnostics();
  return out;
}

ObservationMessage TeamPoseEkf::observations() const {
  ObservationMessage message;
  message.spans.assign(own_spans_.begin(), own_spans_.end());
  const std::int64_t origin_step =
      own_spans_.empty() ? newest_step_ : own_spans_.front().first_world_step - 1;
  const auto origin = std::find_if(own_poses_.begin(), own_poses_.end(),
                                   [&](const OwnPose& pose) { return pose.world_step == origin_step; });
  const OwnPose& pose = origin != own_poses_.end() ? *origin : own_poses_.front();
  message.origin_step = pose.world_step;
  message.origin_pose = pose.pose;
  message.origin_covariance = pose.covariance;
  return message;
}

Estimate TeamPoseEkf::estimate() const {
  return pose_internal::pose_estimate(current_.pose(setup_.id), current_.pose_covariance(setup_.id), true);
}

}  // namespace swarmloc::estimators
