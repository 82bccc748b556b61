#pragma once
// The joint pose EKF of every robot at the fusion centre (the model: pose/kernels.hpp).
#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/pose/kernels.hpp"

namespace swarmloc::estimators {

/// Joint pose EKF of N robots (state 3N, robot i at entries 3i..3i+2 in the order of `setups`). Same
/// prediction per robot and the same landmark rows as PoseEkf; a robot-robot pair is a row of the joint
/// state with both robots' Jacobian blocks (no interlacing: the cross-covariances are kept). One stacked
/// update per step with every robot's pairs, same optional gate. Not an Estimator.
class CentralizedPoseEkf {
 public:
  /// Throws std::invalid_argument on duplicate ids, a non-finite prior or non-positive initial stds.
  CentralizedPoseEkf(const std::vector<AgentSetup>& setups, const KalmanFilterParams& params);

  /// Appends a robot with this pose and covariance, uncorrelated with the others (a team member that joins
  /// late, team_pose_ekf). Throws std::invalid_argument on a known id or a non-finite pose or covariance.
  void add_robot(AgentId id, const Pose& pose, const Mat3& covariance);

  /// batches[i]: robot i's batch for this step, or nullptr. Throws std::invalid_argument if
  /// batches.size() differs from the number of robots. A pair to an unknown peer (or to itself) is skipped.
  void step(const std::vector<const MeasurementBatch*>& batches);

  /// Position and its 2×2 covariance block; valid = false for an unknown id.
  [[nodiscard]] Estimate estimate(AgentId id) const;
  /// Throws std::invalid_argument for an unknown id.
  [[nodiscard]] Pose pose(AgentId id) const;

  [[nodiscard]] int num_robots() const { return static_cast<int>(ids_.size()); }
  /// The robots in state order.
  [[nodiscard]] const std::vector<AgentId>& ids() const { return ids_; }
  /// Robot `id`'s 3×3 (x, y, θ) covariance block; throws std::invalid_argument for an unknown id.
  [[nodiscard]] Mat3 pose_covariance(AgentId id) const;
  [[nodiscard]] const VecX& state() const { return x_; }
  [[nodiscard]] const MatX& covariance() const { return P_; }
  /// Counters of the last step summed over robots (same meaning as PoseEkf's).
  [[nodiscard]] const StepDiagnostics& last_diagnostics() const { return diagnostics_; }
  [[nodiscard]] std::int64_t odometry_segments_skipped() const { return segments_skipped_; }

 private:
  [[nodiscard]] std::optional<int> index_of(AgentId id) const;
  /// The prediction, robot by robot (the joint F and Q are block diagonal).
  void predict(const std::vector<const MeasurementBatch*>& batches);
  /// Rows of every robot's pairs at the predicted joint state (skipped pairs counted in diagnostics_).
  RangeBearingRows joint_rows(const std::vector<const MeasurementBatch*>& batches);

  std::vector<AgentId> ids_;
  KalmanFilterParams params_;
  VecX x_;
  MatX P_;
  StepDiagnostics diagnostics_;
  std::int64_t segments_skipped_ = 0;
  std::vector<SightingHistory> sightings_;  ///< per robot, in state order
};

}  // namespace swarmloc::estimators
