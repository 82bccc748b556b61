#pragma once
// The centralized batch MAP smoother of a pose-state run (docs/real-data.md, "The batch smoother"): every
// robot's pose (x, y, θ) at every world step, solved from ALL the run's odometry and range-bearings at once.
// It is the non-causal optimum of the data the filters see step by step: the reference the centralized
// pose EKF (the causal optimum, up to linearization) and the distributed filters are measured against.
//
// Factors, with the filters' own models (estimators/pose/kernels.hpp, models/pose_models.hpp):
// - a prior on each robot's start pose, N(start, diag(σ₀², σ₀², σ_θ²));
// - an odometry factor between each robot's consecutive step poses: the step's segments composed by
//   estimators::propagate_pose from the origin into one relative pose Δ with covariance Q (the unicycle is
//   invariant under rotation and translation, so x_k = x_{k−1} ⊕ Δ with noise R(θ_{k−1}) Q R(θ_{k−1})ᵀ,
//   exactly the filters' prediction); without odometry Δ = 0 and Q = the filters' position random walk;
// - a unary range-bearing factor per landmark sighting, the landmark's covariance folded into the noise
//   as the per-agent filters do;
// - a binary range-bearing factor per robot–robot sighting (the seer's pose, the seen robot's position).
// Transport-free: no I/O, logging, clocks.
#include <cstdint>
#include <optional>
#include <vector>

#include "swarmloc/estimators/kalman/params.hpp"
#include "swarmloc/estimators/messages.hpp"
#include "swarmloc/models/pose_models.hpp"

namespace swarmloc::world {

using models::Mat3;
using models::Pose;

/// Added to every odometry covariance (m², m², rad²): a single unicycle segment has rank-2 noise (none
/// across the heading), a step without odometry none on the heading, and an infinite information would make
/// the factor a hard constraint. (1 mm)² is 0.4 % of one 0.1 s step's distance variance on MRCLAM.
inline constexpr double kPoseSmootherOdometryJitter = 1e-6;

/// x_k = x_{k−1} ⊕ delta, noise covariance `covariance` in the frame of x_{k−1}.
struct PoseOdometryFactor {
  int robot = 0;
  std::int64_t step = 0;  ///< links step − 1 to step
  Pose delta = Pose::Zero();
  Mat3 covariance = Mat3::Identity();
};

/// A range-bearing pair of robot `robot` at `step`: to a landmark (unary) or to robot `peer` (binary).
struct PoseRangeBearingFactor {
  int robot = 0;
  std::int64_t step = 0;
  int peer = -1;  ///< −1: a landmark
  Vec2 landmark_m = Vec2::Zero();
  Vec2 measured = Vec2::Zero();  ///< (range, bearing)
  /// R̃: diag(σ_r², σ_β²), for a landmark plus its covariance folded in as diag(σ_L², σ_L²/ρ²) with
  /// σ_L² = tr(Σ_L)/2 and ρ the measured range (H_t Σ_L H_tᵀ exactly for an isotropic Σ_L; fixed, so
  /// the cost is one function of the poses).
  Mat2 noise = Mat2::Zero();
};

struct PoseSmootherProblem {
  int robots = 0;
  std::int64_t steps = 0;
  /// Per robot: the prior on its pose at step 0, as the filters hold it after step 0's prediction.
  std::vector<Pose> start;
  std::vector<Mat3> start_covariance;
  std::vector<PoseOdometryFactor> odometry;
  std::vector<PoseRangeBearingFactor> range_bearings;
  double gate_chi2 = 0.0;  ///< the filters' range_bearing_gate_chi2 (0: no gate)
};

/// An empty problem of `robots` robots starting at `start` (its headings) with the filters' prior.
PoseSmootherProblem make_pose_smoother_problem(const std::vector<Vec2>& start_m,
                                               const std::vector<double>& start_heading_rad,
                                               const estimators::KalmanFilterParams& params);

/// Adds world step `step`'s batches (index = robot), in step order from 0: one odometry factor per robot
/// (at step 0 the filters' first prediction moves the prior instead) and its usable range-bearings
/// (finite, positive stds; robot peers within the problem, not itself).
void add_pose_smoother_step(PoseSmootherProblem& problem, std::int64_t step,
                            const std::vector<estimators::MeasurementBatch>& batches,
                            const estimators::KalmanFilterParams& params);

struct PoseSmootherSolution {
  std::vector<Pose> poses;      ///< index step · robots + robot
  std::vector<Mat3> marginals;  ///< the same index; empty unless asked for
  std::vector<bool> used;       ///< per range-bearing factor: used in the final solve
  int iterations = 0;           ///< Levenberg–Marquardt iterations, all gating rounds
  int gating_rounds = 0;
  bool converged = false;
  int range_bearings_used = 0;
  int range_bearings_gated = 0;
  double cost = 0.0;  ///< Σ rᵀ W r at the solution over the used factors
};

struct PoseSmootherOptions {
  int max_iterations = 50;
  int max_gating_rounds = 4;
  bool marginals = true;
};

/// Solves the problem from `initial` (index step · robots + robot, e.g. the centralized EKF's
/// trajectory). Gating (the filters drop misidentified barcodes with the chi-square gate; one wrong
/// barcode in a least-squares smoother would pull whole trajectory segments): a pair is first used iff its
/// residual at `initial` passes the gate against S = R̃ + J P Jᵀ, P the initial marginals (the EKF's own
/// innovation test, block-diagonal); then, after each solve, iff its residual at the solution passes
/// rᵀ R̃⁻¹ r <= gate, re-solving until the set of used pairs stops changing (at most max_gating_rounds).
/// `initial_marginals` empty: the first gate uses R̃ alone.
PoseSmootherSolution solve_pose_smoother(const PoseSmootherProblem& problem, const std::vector<Pose>& initial,
                                         const std::vector<Mat3>& initial_marginals,
                                         const PoseSmootherOptions& options = {});

// ---- Exposed for tests ----

/// Residual of an odometry factor and its Jacobians: r = (R(θ_a)ᵀ(p_b − p_a) − Δ_p, wrap(θ_b − θ_a − Δ_θ)).
struct OdometryResidual {
  Pose r = Pose::Zero();
  Mat3 d_a = Mat3::Zero();
  Mat3 d_b = Mat3::Zero();
};
OdometryResidual odometry_residual(const Pose& a, const Pose& b, const Pose& delta);

/// Residual z − h(pose, target) (bearing wrapped) and its Jacobians; nullopt if the target sits on the pose.
struct RangeBearingResidual {
  Vec2 r = Vec2::Zero();
  models::Mat23 d_pose = models::Mat23::Zero();
  Mat2 d_target = Mat2::Zero();
};
std::optional<RangeBearingResidual> range_bearing_residual(const Pose& pose, const Vec2& target,
                                                           const Vec2& measured);

/// ∇ of the cost ½ Σ rᵀ W r at `poses` (prior, odometry and the range-bearings with `used[m]`): −b of
/// the normal equations H δ = b, zero at the solution.
VecX pose_smoother_gradient(const PoseSmootherProblem& problem, const std::vector<Pose>& poses,
                            const std::vector<bool>& used);

}  // namespace swarmloc::world
