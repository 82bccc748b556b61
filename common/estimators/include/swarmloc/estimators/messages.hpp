#pragma once
// Transport-free message and measurement types. The DDS layer converts IDL samples to and from these
// in common/dds/src/convert.cpp (and convert_observations.cpp); estimators never see a wire type.
#include <cstdint>
#include <optional>
#include <vector>

#include "swarmloc/core/altitude.hpp"
#include "swarmloc/core/types.hpp"

namespace swarmloc::estimators {

// ---- Measurements an agent receives for one world step ----
struct RangeMeasurement {
  AgentId peer = 0;
  double range_m = 0.0;
  double std_m = 0.0;
};

struct AbsoluteFix {
  Vec2 position_m = Vec2::Zero();
  Mat2 covariance = Mat2::Zero();  ///< zero = exactly known (anchor)
  /// 3-D worlds: the fix's z, with covariance(0, 0)'s variance, independent of x and y (docs/design.md §3.1).
  std::optional<double> z_m;
};

struct MotionInput {
  Vec2 velocity_mps = Vec2::Zero();
  double dt_s = 0.0;
  Mat2 process_cov = Mat2::Zero();
};

/// Angle of the peer seen from this agent in the global frame (docs/algorithms.md §1.1).
struct BearingMeasurement {
  AgentId peer = 0;
  double bearing_rad = 0.0;
  double std_rad = 0.0;
};

/// s = x_peer − x_self + ε, ε ~ N(0, covariance) (Atanasov et al. eq. (3)).
struct RelativeMeasurement {
  AgentId peer = 0;
  Vec2 delta_m = Vec2::Zero();
  Mat2 covariance = Mat2::Identity();
};

/// One single-bounce (or LOS) path between this agent and a peer (Leng et al. eq. (1), docs/algorithms.md
/// §5.1): its length and the angles of arrival at both ends, matched across the pair by path_index.
struct MultipathMeasurement {
  AgentId peer = 0;
  int path_index = 0;
  double length_m = 0.0;
  double aoa_here_rad = 0.0;   ///< θ at this agent (direction toward the scatter point)
  double aoa_there_rad = 0.0;  ///< θ at the peer
};

/// An observation of target `target` (Atanasov et al. eq. (2)): linear (kind 0, value = H·y + v) or
/// range–bearing (kind 1, value = (range, bearing)).
struct TargetObservation {
  std::int32_t target = 0;
  Vec2 value = Vec2::Zero();
  Mat2 covariance = Mat2::Identity();
  std::uint8_t kind = 0;
};

/// Unicycle odometry over one interval: forward speed and turn rate in the robot frame, held for dt_s.
struct OdometrySegment {
  double v_mps = 0.0;
  double omega_radps = 0.0;
  double dt_s = 0.0;
};

/// The odometry of one world step (pose-state algorithms), applied segment by segment in order.
/// Noise is white on the inputs with these spectral densities: over a segment of length dt the
/// travelled distance has variance v_std² · dt and the turned angle omega_std² · dt.
struct OdometryInput {
  std::vector<OdometrySegment> segments;
  double v_std = 0.0;      ///< m/√s
  double omega_std = 0.0;  ///< rad/√s
};

/// Range and bearing to a robot peer or to a landmark of known position, bearing measured in this
/// agent's body frame: β = wrap(atan2(y_t − y, x_t − x) − θ) (pose-state algorithms, UTIAS MRCLAM).
struct RangeBearingMeasurement {
  AgentId peer = 0;                  ///< robot peer (unused when landmark)
  bool landmark = false;             ///< true: the target is landmark_m, not a peer's state
  Vec2 landmark_m = Vec2::Zero();    ///< known landmark position
  Mat2 landmark_cov = Mat2::Zero();  ///< its uncertainty (surveyed std²)
  double range_m = 0.0;
  double bearing_rad = 0.0;
  double range_std_m = 0.0;
  double bearing_std_rad = 0.0;
  /// Time from the sighting to the end of its world step (≥ 0): the filters evaluate it at the pose the robot
  /// had then, the step's end with the tail of its odometry undone (docs/algorithms.md §10.4).
  double age_s = 0.0;
};

struct MeasurementBatch {
  std::int64_t world_step = -1;  ///< -1: no batch this step
  double world_time_s = 0.0;
  std::vector<RangeMeasurement> ranges;
  std::vector<BearingMeasurement> bearings;
  std::vector<RelativeMeasurement> relative;
  std::vector<MultipathMeasurement> paths;
  std::vector<TargetObservation> targets;
  std::optional<AbsoluteFix> fix;
  std::optional<MotionInput> motion;
  std::optional<OdometryInput> odometry;                ///< pose-state algorithms only
  std::vector<RangeBearingMeasurement> range_bearings;  ///< pose-state algorithms only
  std::vector<AgentId> neighbours;
};

// ---- Inter-agent messages (one struct per family of docs/design.md §3) ----
/// The sender's own range draws to one neighbour, summarized (dml, docs/algorithms.md §9.1): their
/// information Σ 1/σ² and information-weighted mean. The neighbour adds them to its own draws of the edge.
struct EdgeRangeSummary {
  AgentId peer = 0;
  double information = 0.0;  ///< m⁻²
  double mean_range_m = 0.0;
  /// The peer's published mean as the sender last heard it (dml's negative connectivity, §9.4); the sender's
  /// own mean when it has none (not localized yet, or not heard).
  Vec2 peer_mean_m = Vec2::Zero();
  double peer_z_m = 0.0;  ///< 3-D worlds: the z of peer_mean_m (0 in planar worlds)
};

/// dml: the sender's belief without the message one neighbour sent it, the cavity (docs/algorithms.md §9.2).
/// The neighbour solves against this mean and weighs the edge by this variance, so nothing it told the sender
/// comes back to it.
struct EdgeCavity {
  AgentId peer = 0;
  Vec2 offset_m = Vec2::Zero();  ///< the cavity's mean minus the sender's mean_m
  double offset_z_m = 0.0;       ///< 3-D worlds: the z of that offset (0 in planar worlds)
  double variance_m2 = 0.0;      ///< the cavity's variance along the edge (finite, >= 0)
};

/// STATE + COV of the sender's own position.
struct StateMessage {
  /// At most this many cavities per state (the wire's bound); neighbours beyond it get none.
  static constexpr std::size_t kMaxCavities = 64;

  Vec2 mean_m = Vec2::Zero();
  Mat2 covariance = Mat2::Zero();
  bool anchor = false;
  bool active = true;
  std::uint16_t degree = 0;
  std::vector<EdgeRangeSummary> edge_ranges;  ///< dml only: a few edges per message, in rotation
  /// dml only: the sender's own self-check flags its position (docs/algorithms.md §9.5), so a neighbour
  /// that leans on it knows its support is in doubt.
  bool inconsistent = false;
  /// 3-D worlds: z and the z row of the covariance (core/altitude.hpp); empty in planar worlds.
  std::optional<Altitude> altitude = std::nullopt;
  /// dml only: one cavity per neighbour whose message the sender's belief holds.
  std::vector<EdgeCavity> cavities;
};

/// INFO-VEC + INFO-MAT (DLE priors).
struct InformationMessage {
  std::int32_t target = 0;
  VecX info_vec;
  MatX info_mat;
  /// The world step a moving target's prior is predicted to, so a receiver can bring it to its own time
  /// before mixing; −1: not tied to a world step (a static target, a field, no reading yet).
  std::int64_t world_step = -1;
};

/// CONS scalars with (update τ, round t).
struct ConsensusMessage {
  std::int64_t tau = 0;
  std::int32_t round = 0;
  std::vector<double> values;
};

/// One neighbour's message as the sender of a BELIEF added it to its belief, in information form (exact
/// GaBP only, not in Leng et al.): the neighbour `from` subtracts it to get the sender's belief without its
/// own contribution (the cavity).
struct BeliefContribution {
  AgentId from = 0;
  Mat2 information = Mat2::Zero();
  Vec2 info_vec = Vec2::Zero();
};

/// BELIEF of the sender's own position.
struct BeliefMessage {
  std::int64_t iteration = 0;
  Vec2 mean_m = Vec2::Zero();
  Mat2 information = Mat2::Zero();
  bool infinite_information = false;
  /// Exact GaBP: what each neighbour contributed to `information` (empty for Leng et al. as printed).
  std::vector<BeliefContribution> contributions;
};

/// A span of world steps of one robot's own sensor data, as it shares it with its team (team_pose_ekf,
/// docs/algorithms.md §10): normally one step (first_world_step = world_step); a free-run batch that
/// superseded an earlier one covers both, its odometry and sightings belong to world_step.
struct ObservedSteps {
  std::int64_t first_world_step = 0;
  std::int64_t world_step = 0;
  double world_time_s = 0.0;  ///< of world_step (the sightings' time)
  std::optional<OdometryInput> odometry;
  std::vector<RangeBearingMeasurement> range_bearings;
};

/// OBSERVATIONS: the sender's newest spans of its own data, oldest first and consecutive, and its own pose
/// estimate (x, y, θ) just before the oldest span: at origin_step = −1 that is its prior.
struct ObservationMessage {
  std::int64_t origin_step = -1;
  Eigen::Vector3d origin_pose = Eigen::Vector3d::Zero();
  Eigen::Matrix3d origin_covariance = Eigen::Matrix3d::Identity();
  std::vector<ObservedSteps> spans;
};

/// A received message with the sender's identity and step (the mailbox keeps the newest per sender).
/// `sender_step` is expressed in the RECEIVER's step frame: the step at which the message counts as
/// sent (a message that arrives before the receiver's step k counts as sent at k − 1). Agents' own
/// step counters are not comparable across processes (different start times, drifting clocks).
template <typename Message>
struct Received {
  AgentId sender = 0;
  std::int64_t sender_step = 0;
  Message message;
};

/// Everything an agent has from its neighbours at the moment it steps: the newest sample per sender.
struct Inbox {
  std::vector<Received<StateMessage>> states;
  std::vector<Received<InformationMessage>> information;
  std::vector<Received<ConsensusMessage>> consensus;
  std::vector<Received<BeliefMessage>> beliefs;
  std::vector<Received<ObservationMessage>> observations;
};

/// What an estimator wants published after a step (each family optional).
struct Outbox {
  std::optional<StateMessage> state;
  std::optional<InformationMessage> information;
  std::vector<ConsensusMessage> consensus;
  std::optional<BeliefMessage> belief;
  std::optional<ObservationMessage> observations;
};

/// The heading θ of a pose-state estimate, with the θ row of its (x, y, θ) covariance.
struct HeadingEstimate {
  double heading_rad = 0.0;
  double variance_rad2 = 0.0;
  Vec2 position_cov_m_rad = Vec2::Zero();  ///< (cov(x, θ), cov(y, θ))
};

/// Position estimate of the agent itself (or of the target it estimates, dle).
struct Estimate {
  Vec2 mean_m = Vec2::Zero();
  Mat2 covariance = Mat2::Identity() * 1e12;
  bool valid = false;
  VecX field;  ///< joint_field: the field estimate ŷ, one value per cell (empty otherwise)
  /// The estimator's self-check (docs/algorithms.md §1.6) finds its solution inconsistent with its data:
  /// likely a wrong (folded, flipped) solution, whatever the covariance says. Always false for estimators
  /// without a self-check.
  bool inconsistent = false;
  /// Pose-state algorithms (pose_ekf, pose_ieif, dead_reckoning): the heading and its covariance with the
  /// position. Empty for position-only algorithms. On the wire in Estimate.heading (scoring: NEES3);
  /// the ROS 2 pose uses it too.
  std::optional<HeadingEstimate> heading;
  /// 3-D worlds: z and the z row of the (x, y, z) covariance (core/altitude.hpp); empty in planar worlds.
  std::optional<Altitude> altitude = std::nullopt;
};

}  // namespace swarmloc::estimators
