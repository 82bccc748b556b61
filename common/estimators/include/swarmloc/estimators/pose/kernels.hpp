#pragma once
// The kernels shared by the pose-state (x, y, θ) filters for ground robots with unicycle odometry and
// body-frame range-bearing measurements to landmarks and to other robots (UTIAS MRCLAM). The filters, one
// file each: PoseEkf (pose_ekf.hpp, Kalman form), PoseIeif (pose_ieif.hpp, information form of the same
// model), DeadReckoning (dead_reckoning.hpp, prediction only) and, at the fusion centre,
// CentralizedPoseEkf (centralized_pose_ekf.hpp, joint state of every robot). No transport, clock, RNG, I/O
// or logging inside.
//
// Model. Prediction: every OdometrySegment in order through models::unicycle_step, P ← F P Fᵀ + Q with
// Q = G diag(v_std²·dt, ω_std²·dt) Gᵀ. Without odometry the pose stays and P gains Q_pos =
// process_noise_std_m²·I on (x, y) only. Update: every range-bearing pair of the batch, all linearized at
// the predicted pose and applied as ONE stacked update (block-diagonal R̃, bearing innovations wrapped);
// the per-agent filters fold the target's 2×2 covariance Σ_t into the noise, R̃ = R + H_t Σ_t H_tᵀ
// ("interlaced", as Ieif/Iekf do for ranges), the centralized filter keeps robot targets in its state.
#include <cstdint>
#include <map>
#include <optional>
#include <string_view>
#include <tuple>
#include <vector>

#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/kalman/params.hpp"
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
                               const KalmanFilterParams& params);

/// Q_pos as a 3×3 matrix (no heading noise).
Mat3 position_random_walk(const KalmanFilterParams& params);

/// One usable range-bearing pair with its target resolved to a 2D Gaussian (per-agent filters).
struct RangeBearingTarget {
  AgentId peer = 0;
  bool landmark = false;
  Vec2 target_m = Vec2::Zero();    ///< landmark_m, or the peer's published mean
  Mat2 target_cov = Mat2::Zero();  ///< landmark_cov, or the peer's covariance (after inflation)
  Vec2 measured = Vec2::Zero();    ///< (range, bearing)
  Mat2 noise = Mat2::Zero();       ///< R = diag(σ_r², σ_β²)
  double age_s = 0.0;              ///< RangeBearingMeasurement::age_s
};

/// The pose a sighting `age_s` before the end of its step was taken from: `end` with the tail of the step's
/// odometry undone (the segments are the step's, in order, the last one ending at the step's end), and its
/// Jacobian with respect to `end`. Without odometry, or with age_s = 0, the pose is `end`.
struct RewoundPose {
  Pose pose = Pose::Zero();
  Mat3 d_end = Mat3::Identity();
};
RewoundPose rewind_pose(const Pose& end, const OdometryInput* odometry, double age_s);

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
                                             const KalmanFilterParams& params);

/// When each robot last sighted each target (a landmark, by its position, or a robot peer), so that a
/// sighting of errors correlated with the last one's counts for what it adds (docs/algorithms.md §10.3):
/// with ρ = exp(−Δt/τ) the correlated part's variance is inflated by (1 + ρ)/(1 − ρ), the asymptotic
/// variance factor of a densely sampled first-order Gauss–Markov error. A first sighting is not inflated.
/// A landmark within params.sighting_cluster_radius_m of one already seen is that landmark's stream.
class SightingHistory {
 public:
  /// Variance factors (range, bearing) for a sighting at `time_s`; records the sighting.
  Vec2 inflation(AgentId peer, bool landmark, const Vec2& landmark_m, double time_s,
                 const KalmanFilterParams& params);

 private:
  struct Key {
    AgentId peer = 0;
    bool landmark = false;
    double x = 0.0;
    double y = 0.0;
    bool operator<(const Key& other) const {
      return std::tie(landmark, peer, x, y) < std::tie(other.landmark, other.peer, other.x, other.y);
    }
  };
  /// A robot peer's stream, or the stream of the landmark (or of the first one seen within the cluster
  /// radius of it).
  [[nodiscard]] Key key_of(AgentId peer, bool landmark, const Vec2& landmark_m,
                           const KalmanFilterParams& params) const;
  std::map<Key, double> last_time_s_;
};

/// Scales each target's R by its SightingHistory factors (nothing when params model independent sightings).
void weigh_correlated_sightings(std::vector<RangeBearingTarget>& targets, SightingHistory& history,
                                double time_s, const KalmanFilterParams& params);

/// Stacked measurement rows: pair m occupies rows 2m, 2m+1 of H and ν; its noise is noise[m].
struct RangeBearingRows {
  MatX H;                   ///< 2M × n (n = 3 for one robot, 3N for the centralized filter)
  VecX innovation;          ///< ν = (z_r − ρ̂, wrap(z_β − β̂)) per pair
  std::vector<Mat2> noise;  ///< R̃_m (PD)
  int skipped = 0;          ///< pairs dropped: target within kMinDistanceM, R̃ not PD

  [[nodiscard]] int pairs() const { return static_cast<int>(noise.size()); }
};

/// H (2M×3), ν and R̃ = R + H_t Σ_t H_tᵀ of `targets` at the predicted pose.
RangeBearingRows linearize_range_bearings(const Pose& pose, const std::vector<RangeBearingTarget>& targets,
                                          const OdometryInput* odometry = nullptr);

/// 2-dof chi-square gate: drops pair m when νᵀ S⁻¹ ν > chi2_gate, S = H_m P_pred H_mᵀ + R̃_m. Keeps every
/// pair when chi2_gate <= 0, P_pred is not finite, or at least two pairs and more than half of them are
/// outside (then the prediction is what is off, as in gate_ranges). A lone pair outside is dropped.
/// Returns the number of pairs dropped.
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

}  // namespace swarmloc::estimators
