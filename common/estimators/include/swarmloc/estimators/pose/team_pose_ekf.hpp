#pragma once
// The team's joint pose EKF at every robot, from the observations the robots share (docs/algorithms.md §10).
#include <cstdint>
#include <deque>
#include <map>
#include <set>
#include <string_view>

#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/pose/centralized_pose_ekf.hpp"
#include "swarmloc/estimators/pose/kernels.hpp"

namespace swarmloc::estimators {

/// Every robot runs the team's joint pose EKF (CentralizedPoseEkf: the same prediction, rows and gate) on
/// its own data and on the data its team mates share: each OBSERVATIONS sample carries the sender's newest
/// spans of odometry and range-bearing sightings. A settled copy of the joint filter steps world step by
/// world step once every member's data for the step is in (or team_wait_steps have passed); the estimate is
/// that copy brought to the newest world step with whatever has arrived. With every sample delivered, the
/// settled filter is the centralized filter, step for step.
class TeamPoseEkf final : public Estimator {
 public:
  /// params.team_share_spans and team_wait_steps set the sharing and the wait (KalmanFilterParams).
  TeamPoseEkf(const AgentSetup& setup, const KalmanFilterParams& params);

  [[nodiscard]] std::string_view name() const override { return "team_pose_ekf"; }
  [[nodiscard]] Outbox initial_outbox() const override;
  StepOutput step(const StepInput& input) override;
  [[nodiscard]] Estimate estimate() const override;

  /// The newest world step the settled filter has processed (−1: none).
  [[nodiscard]] std::int64_t settled_step() const { return settled_step_; }
  [[nodiscard]] const CentralizedPoseEkf& settled() const { return settled_; }

 private:
  /// One span of a member's data, as the joint filter steps it.
  struct LoggedSpan {
    std::int64_t first_world_step = 0;
    MeasurementBatch batch;
  };
  using Log = std::map<std::int64_t, LoggedSpan>;  ///< by the span's last world step

  struct OwnPose {
    std::int64_t world_step = -1;
    Pose pose = Pose::Zero();
    Mat3 covariance = Mat3::Identity();
  };

  void record_own(const MeasurementBatch& batch);
  void absorb(AgentId sender, const ObservationMessage& message);
  void store(Log& log, const ObservedSteps& span) const;
  /// Joins the sender to the settled filter if its origin is at or before the settled step.
  void try_join(AgentId sender);
  [[nodiscard]] bool covers(AgentId id, std::int64_t world_step) const;
  [[nodiscard]] bool complete(std::int64_t world_step) const;
  [[nodiscard]] std::vector<const MeasurementBatch*> batches_at(const CentralizedPoseEkf& filter,
                                                                std::int64_t world_step) const;
  void advance_settled();
  [[nodiscard]] bool has_span_at(AgentId id, std::int64_t world_step) const;
  /// current_ = the settled filter stepped to the newest world step with what has arrived.
  void bring_current();
  void prune_logs();
  [[nodiscard]] ObservationMessage observations() const;

  AgentSetup setup_;
  KalmanFilterParams params_;
  CentralizedPoseEkf settled_;
  std::int64_t settled_step_ = -1;
  CentralizedPoseEkf current_;
  std::int64_t newest_step_ = -1;  ///< own newest world step
  std::map<AgentId, Log> logs_;    ///< every member's spans after the settled step, this robot's included
  std::map<AgentId, ObservationMessage> waiting_;  ///< newest sample of members not joined yet
  std::set<AgentId> expected_;                     ///< the batches' neighbours
  std::deque<ObservedSteps> own_spans_;
  std::deque<OwnPose> own_poses_;  ///< own estimate after each of own_spans_ (and one before them)
};

}  // namespace swarmloc::estimators
