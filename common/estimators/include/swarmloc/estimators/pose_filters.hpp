#pragma once
// Pose-state (x, y, θ) filters for ground robots with unicycle odometry and body-frame range-bearing
// measurements to landmarks and to other robots (UTIAS MRCLAM). Per-agent: PoseEkf (Kalman form),
// PoseIeif (information form of the same model), DeadReckoning (prediction only). Fusion centre:
// CentralizedPoseEkf (joint state of every robot). No transport, clock, RNG, I/O or logging inside.
//
// Model. Prediction: every OdometrySegment in order through models::unicycle_step, P ← F P Fᵀ + Q with
// Q = G diag(v_std²·dt, ω_std²·dt) Gᵀ. Without odometry the pose stays and P gains Q_pos =
// process_noise_std_m²·I on (x, y) only. Update: every range-bearing pair of the batch, all linearized at
// the predicted pose and applied as ONE stacked update (block-diagonal R̃, bearing innovations wrapped);
// the per-agent filters fold the target's 2×2 covariance Σ_t into the noise, R̃ = R + H_t Σ_t H_tᵀ
// ("interlaced", as Ieif/Iekf do for ranges), the centralized filter keeps robot targets in its state.
#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/messages.hpp"
#include "swarmloc/models/pose_models.hpp"

namespace swarmloc::estimators {

using models::Pose;
using Mat3 = models::Mat3;

// ---- Kernels shared by the pose filters (exposed so that tests can check them one by one) ----

/// The odometry of one step composed into one transition: pose = f(x), P_{k|k−1} = F P Fᵀ + Q.
struct PosePropagation {
  Pose pose = Pose::Zero();
  Mat3 F = Mat3::Identity();
  Mat3 Q = Mat3::Zero();
  int segments_used = 0;
  int segments_skipped = 0;  ///< non-finite v, ω or dt, dt < 0, or non-finite/negative v_std, omega_std
};

/// Applies the batch's odometry segment by segment. A segment that is not usable is skipped (the pose
/// does not move for it); if any was skipped, or there is no odometry (no batch, no OdometryInput),
/// Q_pos = process_noise_std_m²·I on (x, y) is added once for the step. An OdometryInput with an
/// unusable v_std/omega_std counts all its segments (at least one) as skipped.
PosePropagation propagate_pose(const Pose& pose, const MeasurementBatch* batch,
                               const KalmanFamilyParams& params);

/// Q_pos as a 3×3 matrix (no heading noise).
Mat3 position_random_walk(const KalmanFamilyParams& params);

/// One usable range-bearing pair with its target resolved to a 2D Gaussian (per-agent filters).
struct RangeBearingTarget {
  AgentId peer = 0;
  bool landmark = false;
  Vec2 target_m = Vec2::Zero();    ///< landmark_m, or the peer's published mean
  Mat2 target_cov = Mat2::Zero();  ///< landmark_cov, or the peer's covariance (after inflation)
  Vec2 measured = Vec2::Zero();    ///< (range, bearing)
  Mat2 noise = Mat2::Zero();       ///< R = diag(σ_r², σ_β²)
};

struct RangeBearingSelection {
  std::vector<RangeBearingTarget> targets;
  int skipped = 0;  ///< pairs dropped: bad values or std, bad landmark, peer without a usable message
};

/// Staleness of a peer's pose message: it holds the sender's POSTERIOR at its step s (unlike the IEIF's
/// prediction), so at the receiver's step k the peer has moved for a = max(0, k − s) steps.
std::int64_t pose_message_age_steps(std::int64_t local_step, std::int64_t sender_step);

/// Pairs every range-bearing of the batch with its target. A pair is skipped when its range or bearing
/// is not finite, the range is negative, a std is not finite and > 0; a landmark when its position is
/// not finite or its covariance not finite and PSD; a robot peer when it is this agent, has no state
/// message in the inbox (the newest per sender is used), or the message has a non-finite mean or
/// covariance or trace(P) > params.max_neighbour_variance_m2 (after inflation). Non-anchor peer
/// covariances are inflated by a·Q_pos (pose_message_age_steps) when params.inflate_stale.
RangeBearingSelection collect_range_bearings(const StepInput& input, AgentId self,
                                             const KalmanFamilyParams& params);

/// Stacked measurement rows: pair m occupies rows 2m, 2m+1 of H and ν; its noise is noise[m].
struct RangeBearingRows {
  MatX H;                   ///< 2M × n (n = 3 for one robot, 3N for the centralized filter)
  VecX innovation;          ///< ν = (z_r − ρ̂, wrap(z_β − β̂)) per pair
  std::vector<Mat2> noise;  ///< R̃_m (PD)
  int skipped = 0;          ///< pairs dropped: target within kMinDistanceM, R̃ not PD

  [[nodiscard]] int pairs() const { return static_cast<int>(noise.size()); }
};

/// H (2M×3), ν and R̃ = R + H_t Σ_t H_tᵀ of `targets` at the predicted pose.
RangeBearingRows linearize_range_bearings(const Pose& pose, const std::vector<RangeBearingTarget>& targets);

/// 2-dof chi-square gate: drops pair m when νᵀ S⁻¹ ν > chi2_gate, S = H_m P_pred H_mᵀ + R̃_m. Keeps every
/// pair when chi2_gate <= 0, P_pred is not finite, or more than half of the pairs are outside (the same
/// rule as gate_ranges: then the prediction is what is off). Returns the number of pairs dropped.
int gate_range_bearings(RangeBearingRows& rows, const MatX& P_pred, double chi2_gate);

/// A = Hᵀ R̃⁻¹ H and b = Hᵀ R̃⁻¹ ν: the information of the stacked rows.
struct RowInformation {
  MatX A;
  VecX b;
};
RowInformation range_bearing_information(const RangeBearingRows& rows);

/// Stacked Kalman update with the Joseph form, through the push-through identity (as kalman_update):
/// K ν = (I + P A)⁻¹ P b, K H = (I + P A)⁻¹ P A, K R̃ Kᵀ = (I + P A)⁻¹ P A P (I + P A)⁻ᵀ. Headings (every
/// third entry) wrapped, covariance symmetrized. nullopt if the result is not finite.
struct StackedUpdate {
  VecX mean;
  MatX covariance;
};
std::optional<StackedUpdate> stacked_kalman_update(const VecX& x_pred, const MatX& P_pred,
                                                   const RangeBearingRows& rows);

// ---- Per-agent filters ----

/// Pose EKF at one robot: x̂ = (x, y, θ), P (3×3), prior (initial_guess_m, initial_heading_rad) with
/// P_0 = diag(σ_0², σ_0², σ_θ²). Each step: prediction through the batch's odometry, then one stacked
/// update with all range-bearing pairs linearized at the predicted pose (landmarks and interlaced robot
/// peers, optional 2-dof gate). Publishes the position block of the posterior (anchor = false,
/// degree = the batch's neighbour count). Diagnostics: neighbours_used = pairs used (landmarks and
/// robots), neighbours_skipped = pairs dropped, ranges_gated = pairs gated.
class PoseEkf final : public Estimator {
 public:
  PoseEkf(const AgentSetup& setup, const KalmanFamilyParams& params);

  [[nodiscard]] std::string_view name() const override { return "pose_ekf"; }
  [[nodiscard]] Outbox initial_outbox() const override;
  StepOutput step(const StepInput& input) override;
  [[nodiscard]] Estimate estimate() const override;

  [[nodiscard]] const Pose& pose() const { return x_; }
  [[nodiscard]] double heading_rad() const { return x_.z(); }
  [[nodiscard]] const Mat3& covariance() const { return P_; }
  /// Odometry segments skipped since construction (propagate_pose).
  [[nodiscard]] std::int64_t odometry_segments_skipped() const { return segments_skipped_; }

 private:
  AgentSetup setup_;
  KalmanFamilyParams params_;
  Pose x_;
  Mat3 P_;
  int degree_ = 0;
  std::int64_t segments_skipped_ = 0;
};

/// The PoseEkf model in information form: Ψ = P⁻¹, ŷ = Ψ x̂ (derived). Prediction in the form that is
/// exact for P ← F P Fᵀ + Q: Ψ_F = F⁻ᵀ Ψ F⁻¹, Ψ_{k|k−1} = (I + Ψ_F Q)⁻¹ Ψ_F (F is unit upper
/// triangular, always invertible). Update: Ψ += Hᵀ R̃⁻¹ H, ŷ += Hᵀ R̃⁻¹ (ν + H x̂_{k|k−1}) with every pair
/// of the step stacked, x̂ = Ψ⁻¹ ŷ. Agrees with PoseEkf up to rounding. Same inputs, rules and messages.
class PoseIeif final : public Estimator {
 public:
  PoseIeif(const AgentSetup& setup, const KalmanFamilyParams& params);

  [[nodiscard]] std::string_view name() const override { return "pose_ieif"; }
  [[nodiscard]] Outbox initial_outbox() const override;
  StepOutput step(const StepInput& input) override;
  [[nodiscard]] Estimate estimate() const override;

  [[nodiscard]] const Pose& pose() const { return x_; }
  [[nodiscard]] double heading_rad() const { return x_.z(); }
  [[nodiscard]] const Mat3& information() const { return Psi_; }
  [[nodiscard]] Pose information_vector() const { return Psi_ * x_; }
  /// Ψ⁻¹, or kUndefinedVarianceM2·I if Ψ is not PD.
  [[nodiscard]] Mat3 covariance() const;
  [[nodiscard]] std::int64_t odometry_segments_skipped() const { return segments_skipped_; }

 private:
  AgentSetup setup_;
  KalmanFamilyParams params_;
  Pose x_;
  Mat3 Psi_;
  int degree_ = 0;
  std::int64_t segments_skipped_ = 0;
};

/// Odometry only (a baseline): the PoseEkf prediction, never an update. Publishes like PoseEkf.
class DeadReckoning final : public Estimator {
 public:
  DeadReckoning(const AgentSetup& setup, const KalmanFamilyParams& params);

  [[nodiscard]] std::string_view name() const override { return "dead_reckoning"; }
  [[nodiscard]] Outbox initial_outbox() const override;
  StepOutput step(const StepInput& input) override;
  [[nodiscard]] Estimate estimate() const override;

  [[nodiscard]] const Pose& pose() const { return x_; }
  [[nodiscard]] double heading_rad() const { return x_.z(); }
  [[nodiscard]] const Mat3& covariance() const { return P_; }
  [[nodiscard]] std::int64_t odometry_segments_skipped() const { return segments_skipped_; }

 private:
  AgentSetup setup_;
  KalmanFamilyParams params_;
  Pose x_;
  Mat3 P_;
  int degree_ = 0;
  std::int64_t segments_skipped_ = 0;
};

// ---- Fusion centre ----

/// Joint pose EKF of N robots (state 3N, robot i at entries 3i..3i+2 in the order of `setups`). Same
/// prediction per robot and the same landmark rows as PoseEkf; a robot-robot pair is a row of the joint
/// state with both robots' Jacobian blocks (no interlacing: the cross-covariances are kept). One stacked
/// update per step with every robot's pairs, same optional gate. Not an Estimator.
class CentralizedPoseEkf {
 public:
  /// Throws std::invalid_argument on duplicate ids, a non-finite prior or non-positive initial stds.
  CentralizedPoseEkf(const std::vector<AgentSetup>& setups, const KalmanFamilyParams& params);

  /// batches[i]: robot i's batch for this step, or nullptr. Throws std::invalid_argument if
  /// batches.size() differs from the number of robots. A pair to an unknown peer (or to itself) is skipped.
  void step(const std::vector<const MeasurementBatch*>& batches);

  /// Position and its 2×2 covariance block; valid = false for an unknown id.
  [[nodiscard]] Estimate estimate(AgentId id) const;
  /// Throws std::invalid_argument for an unknown id.
  [[nodiscard]] Pose pose(AgentId id) const;

  [[nodiscard]] int num_robots() const { return static_cast<int>(ids_.size()); }
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
  KalmanFamilyParams params_;
  VecX x_;
  MatX P_;
  StepDiagnostics diagnostics_;
  std::int64_t segments_skipped_ = 0;
};

}  // namespace swarmloc::estimators
