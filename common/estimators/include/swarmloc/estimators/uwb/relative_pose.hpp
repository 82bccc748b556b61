#pragma once
// Relative pose of a peer vehicle from UWB ranges between the antennas of the two vehicles (multi-antenna
// ranging, docs/algorithms.md §11): a filter over the peer's position and heading in my level frame, fed by
// one window of antenna-pair ranges at a time. No transport, clock, RNG, I/O or logging inside.
//
// Frames. My level frame has its origin at my body origin, z up (gravity), x along my heading: my body frame
// with roll and pitch undone, which an IMU gives. The peer's pose in it is (t, ψ): position t and heading ψ
// (peer yaw − my yaw). An antenna with lever arm a in my body frame sits at T_me·a, one with lever arm b in
// the peer's body frame at t + Rz(ψ)·T_peer·b, with T = Ry(pitch)·Rx(roll) of each vehicle.
#include <map>
#include <optional>
#include <vector>

#include "swarmloc/core/types.hpp"

namespace swarmloc::estimators::uwb {

using Vec4 = Eigen::Vector4d;
using Mat4 = Eigen::Matrix4d;

/// Roll and pitch of a vehicle as its IMU gives them (gravity-referenced; no heading).
struct Tilt {
  double roll_rad = 0.0;
  double pitch_rad = 0.0;
};

/// Ry(pitch)·Rx(roll): body frame to level frame.
Mat3 level_rotation(const Tilt& tilt);
Mat3 yaw_rotation(double yaw_rad);

/// The peer's pose in my level frame.
struct RelativePose {
  Vec3 position_m = Vec3::Zero();
  double heading_rad = 0.0;
  [[nodiscard]] Vec4 vector() const { return {position_m.x(), position_m.y(), position_m.z(), heading_rad}; }
  static RelativePose from(const Vec4& v) { return {v.head<3>(), v(3)}; }
};

/// Antennas of `count` on a horizontal ring of `radius_m` in the body x-y plane, antenna i at angle
/// first_angle_rad + i·2π/count.
std::vector<Vec3> ring_lever_arms(int count, double radius_m, double first_angle_rad);

/// A range's bias (measured − geometric), learned offline (docs/real-data.md, "MURP"): one offset per antenna
/// of each vehicle (its delay as either end of a two-way exchange) plus a function of the geometry:
/// coefficients_m · geometry_features(…).
struct RangeBias {
  static constexpr int kFeatures = 5;
  using Features = Eigen::Matrix<double, kFeatures, 1>;
  VecX my_antenna_offsets_m;    ///< empty: zero
  VecX peer_antenna_offsets_m;  ///< empty: zero
  Features coefficients_m = Features::Zero();
  [[nodiscard]] double at(int my_antenna, int peer_antenna, const Features& features) const;
};

/// The geometry a range's bias depends on: s = sin of the line of sight's elevation, and how squarely each
/// antenna faces the other vehicle (cosine of the angle between its lever arm and the line of sight, in its
/// body frame; an antenna on the far side of its vehicle sees the other through the airframe):
/// (|s|, s², s, f_mine + f_peer, f_mine² + f_peer²).
RangeBias::Features geometry_features(double sin_elevation, double facing_mine, double facing_peer);

/// One window: ranges_m(i, j) between my antenna i and the peer's antenna j (NaN: no reading).
struct RangeWindow {
  MatX ranges_m;
  /// Spread (std) of the readings averaged into each range; empty: unknown. Ranges whose readings scatter
  /// (multipath, blocked line of sight) are trusted less (RelativePoseParams::spread_noise_gain).
  MatX range_spread_m;
  Tilt mine;
  Tilt peer;
  /// Peer altitude − my altitude as both vehicles' altimeters give it; nullopt: none.
  std::optional<double> altitude_difference_m;
};

struct RelativePoseParams {
  std::vector<Vec3> my_lever_arms_m;
  std::vector<Vec3> peer_lever_arms_m;
  RangeBias bias;
  double range_std_m = 0.08;  ///< one window's mean range about its bias-corrected model
  /// A range whose readings spread by s has std √(range_std_m² + (gain·s²)²) (measured: docs/real-data.md).
  double spread_noise_gain = 0.0;
  double huber_threshold = 1.5;  ///< robust loss: residuals beyond this many stds weigh less
  double altitude_std_m = 0.14;  ///< of altitude_difference_m
  // The random walks of the relative pose between windows, once both vehicles' gyro turns are applied: ground
  // vehicles that drive about 1–2 m/s make the position's walk wide (docs/real-data.md, "MURP").
  double position_walk_mps = 3.0;   ///< m/√s per axis
  double heading_walk_radps = 0.2;  ///< rad/√s
  int iterations = 6;               ///< Gauss–Newton iterations per update
  /// Mean robust cost per range above which the filter takes itself for lost and solves the window afresh
  /// (a standardized residual of 3 costs 3.4 with the default Huber threshold).
  double relock_cost_per_range = 3.0;
};

/// The model's predicted ranges and their Jacobian for a pose (rows: the valid entries of `window`, column
/// major; columns: t then ψ). Exposed for tests (finite differences).
struct RangePrediction {
  VecX predicted_m;  ///< geometric range + bias
  VecX std_m;        ///< each range's std
  Eigen::Matrix<double, Eigen::Dynamic, 4> jacobian;
  VecX measured_m;
};
RangePrediction predict_ranges(const RelativePose& pose, const RangeWindow& window,
                               const RelativePoseParams& params);

class RelativePoseFilter {
 public:
  explicit RelativePoseFilter(RelativePoseParams params);

  /// Moves the pose by the two vehicles' heading changes over dt_s (from their gyros: mine rotates my frame,
  /// the peer's turns the peer) and grows the uncertainty by dt_s of the random walks. No-op before the
  /// first update.
  void predict(double dt_s, double my_turn_rad = 0.0, double peer_turn_rad = 0.0);
  /// Folds one window in. The first usable window (or one after reset()) is solved from a grid of starts.
  /// Returns false (nothing changed) when fewer than four ranges are valid.
  bool update(const RangeWindow& window);
  void reset() { initialized_ = false; }

  [[nodiscard]] bool initialized() const { return initialized_; }
  [[nodiscard]] RelativePose pose() const { return RelativePose::from(mean_); }
  [[nodiscard]] const Mat4& covariance() const { return covariance_; }
  /// Windows after which the filter replaced its solution with a fresh one (relock_cost_per_range).
  [[nodiscard]] int relocks() const { return relocks_; }

 private:
  void initialize(const RangeWindow& window);
  void relock_if_lost(const RangeWindow& window);
  /// Robust Gauss–Newton on the ranges (and altitude) with prior (mean, information); updates mean_,
  /// covariance_.
  void solve(const RangeWindow& window, const Vec4& prior_mean, const Mat4& prior_information);

  RelativePoseParams params_;
  bool initialized_ = false;
  Vec4 mean_ = Vec4::Zero();
  Mat4 covariance_ = Mat4::Identity();
  int relocks_ = 0;
};

struct PoseEstimate {
  RelativePose pose;
  Mat4 covariance = Mat4::Identity();
};

/// A peer's own estimate of another peer (`to` in `from`'s level frame), as it publishes it.
struct PeerRelation {
  AgentId from = 0;
  AgentId to = 0;
  PoseEstimate estimate;
};

/// Fuses my estimates of every peer with the peers' estimates of each other (loop closure over the team,
/// docs/algorithms.md §11.4): one joint Gauss–Newton solve for all peers' poses in my level frame. A relation
/// whose `from` or `to` I have no estimate of is not used. A relation published both ways (p→q and q→p) comes
/// from the same two-way exchanges, so each direction counts half.
std::map<AgentId, PoseEstimate> fuse_team(const std::map<AgentId, PoseEstimate>& mine,
                                          const std::vector<PeerRelation>& relations);

/// C's pose in B's level frame from B's and C's poses in mine.
RelativePose compose_relative(const RelativePose& b, const RelativePose& c);

}  // namespace swarmloc::estimators::uwb
