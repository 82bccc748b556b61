// The batch MAP smoother of a pose-state run (pose_smoother.hpp): Levenberg–Marquardt on the sparse normal
// equations with Eigen's SimplicialLDLT in the unknowns' own step-major order (a band: each step's poses
// couple only to the neighbouring steps' and to each other), marginals by selected inversion.
#include "swarmloc/world/pose_smoother.hpp"

#include <Eigen/Cholesky>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>

#include "selected_inversion.hpp"
#include "swarmloc/estimators/pose/kernels.hpp"
#include "swarmloc/models/measurement_models.hpp"

namespace swarmloc::world {
namespace {

using SmootherMatrix = Eigen::SparseMatrix<double>;
using SmootherFactor = Eigen::SimplicialLDLT<SmootherMatrix, Eigen::Lower, Eigen::NaturalOrdering<int>>;
using Mat32 = models::Mat32;

/// A step that moves no unknown by more than this (m or rad) is the last.
constexpr double kSmootherStepTolerance = 1e-8;
constexpr int kSmootherDampingTries = 30;

/// Rows of the normal equations one factor adds: its residual, its weight and the Jacobian block of each
/// of its (at most two) poses. Range-bearings are 2 rows with the peer's θ column zero.
template <int Rows>
struct FactorRows {
  Eigen::Matrix<double, Rows, 1> r;
  Eigen::Matrix<double, Rows, Rows> weight;
  std::array<std::size_t, 2> pose{};
  std::array<Eigen::Matrix<double, Rows, 3>, 2> J;
  std::size_t poses = 1;
};

/// H (lower triangle, as triplets), b = −Σ Jᵀ W r and the cost Σ rᵀ W r.
struct NormalEquations {
  std::vector<Eigen::Triplet<double>> triplets;
  VecX b;
  double cost = 0.0;
  bool with_matrix = true;

  template <int Rows>
  void add(const FactorRows<Rows>& f) {
    const Eigen::Matrix<double, Rows, 1> wr = f.weight * f.r;
    cost += f.r.dot(wr);
    for (std::size_t a = 0; a < f.poses; ++a) {
      b.segment<3>(static_cast<Eigen::Index>(3 * f.pose[a])) -= f.J[a].transpose() * wr;
      if (!with_matrix) continue;
      for (std::size_t c = 0; c < f.poses; ++c) {
        if (f.pose[a] < f.pose[c]) continue;  // the lower triangle only
        const Mat3 block = f.J[a].transpose() * f.weight * f.J[c];
        add_pose_block(f.pose[a], f.pose[c], block);
      }
    }
  }

  void add_pose_block(std::size_t row_pose, std::size_t column_pose, const Mat3& block) {
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        const auto row = static_cast<int>(3 * row_pose) + i;
        const auto column = static_cast<int>(3 * column_pose) + j;
        if (row >= column) triplets.emplace_back(row, column, block(i, j));
      }
    }
  }
};

/// The problem with its weights inverted once: W = Q⁻¹ (jittered) per odometry factor, R̃⁻¹ per pair.
struct WeightedProblem {
  const PoseSmootherProblem& problem;
  std::vector<Mat3> start_weight;
  std::vector<Mat3> odometry_weight;
  std::vector<Mat2> range_bearing_weight;

  explicit WeightedProblem(const PoseSmootherProblem& p) : problem(p) {
    for (const Mat3& covariance : p.start_covariance) start_weight.push_back(covariance.inverse());
    for (const auto& f : p.odometry)
      odometry_weight.push_back((f.covariance + kPoseSmootherOdometryJitter * Mat3::Identity()).inverse());
    for (const auto& f : p.range_bearings) range_bearing_weight.push_back(f.noise.inverse());
  }
  [[nodiscard]] std::size_t index(int robot, std::int64_t step) const {
    return static_cast<std::size_t>(step) * static_cast<std::size_t>(problem.robots) +
           static_cast<std::size_t>(robot);
  }
  [[nodiscard]] std::size_t unknowns() const { return index(0, problem.steps); }
};

FactorRows<3> start_rows(const WeightedProblem& w, const std::vector<Pose>& x, int robot) {
  FactorRows<3> f;
  f.pose[0] = w.index(robot, 0);
  const Pose& pose = x[f.pose[0]];
  const Pose& start = w.problem.start[static_cast<std::size_t>(robot)];
  f.r << pose.head<2>() - start.head<2>(), models::wrap_angle(pose.z() - start.z());
  f.weight = w.start_weight[static_cast<std::size_t>(robot)];
  f.J[0] = Mat3::Identity();
  return f;
}

FactorRows<3> odometry_rows(const WeightedProblem& w, const std::vector<Pose>& x, std::size_t m) {
  const PoseOdometryFactor& factor = w.problem.odometry[m];
  FactorRows<3> f;
  f.poses = 2;
  f.pose = {w.index(factor.robot, factor.step - 1), w.index(factor.robot, factor.step)};
  const OdometryResidual residual = odometry_residual(x[f.pose[0]], x[f.pose[1]], factor.delta);
  f.r = residual.r;
  f.weight = w.odometry_weight[m];
  f.J = {residual.d_a, residual.d_b};
  return f;
}

/// The pair's target: the landmark, or the seen robot's position.
Vec2 target_of(const WeightedProblem& w, const std::vector<Pose>& x, const PoseRangeBearingFactor& factor) {
  return factor.peer < 0 ? factor.landmark_m : Vec2(x[w.index(factor.peer, factor.step)].head<2>());
}

std::optional<FactorRows<2>> range_bearing_rows(const WeightedProblem& w, const std::vector<Pose>& x,
                                                std::size_t m) {
  const PoseRangeBearingFactor& factor = w.problem.range_bearings[m];
  FactorRows<2> f;
  f.pose[0] = w.index(factor.robot, factor.step);
  const auto residual = range_bearing_residual(x[f.pose[0]], target_of(w, x, factor), factor.measured);
  if (!residual) return std::nullopt;
  f.r = residual->r;
  f.weight = w.range_bearing_weight[m];
  f.J[0] = residual->d_pose;
  if (factor.peer >= 0) {
    f.poses = 2;
    f.pose[1] = w.index(factor.peer, factor.step);
    f.J[1].setZero();
    f.J[1].leftCols<2>() = residual->d_target;
  }
  return f;
}

NormalEquations assemble_pose_system(const WeightedProblem& w, const std::vector<Pose>& x,
                                     const std::vector<bool>& used, bool with_matrix) {
  NormalEquations normal;
  normal.with_matrix = with_matrix;
  normal.b = VecX::Zero(static_cast<Eigen::Index>(3 * w.unknowns()));
  if (with_matrix)
    normal.triplets.reserve(18 * w.problem.odometry.size() + 12 * w.problem.range_bearings.size());
  for (int robot = 0; robot < w.problem.robots; ++robot) normal.add(start_rows(w, x, robot));
  for (std::size_t m = 0; m < w.problem.odometry.size(); ++m) normal.add(odometry_rows(w, x, m));
  for (std::size_t m = 0; m < w.problem.range_bearings.size(); ++m) {
    if (!used[m]) continue;
    if (const auto rows = range_bearing_rows(w, x, m)) normal.add(*rows);
  }
  return normal;
}

double cost_at(const WeightedProblem& w, const std::vector<Pose>& x, const std::vector<bool>& used) {
  return assemble_pose_system(w, x, used, false).cost;
}

SmootherMatrix matrix_of(const WeightedProblem& w, const NormalEquations& normal) {
  const auto n = static_cast<Eigen::Index>(3 * w.unknowns());
  SmootherMatrix H(n, n);
  H.setFromTriplets(normal.triplets.begin(), normal.triplets.end());
  return H;
}

std::vector<Pose> moved(const std::vector<Pose>& x, const VecX& delta) {
  std::vector<Pose> out = x;
  for (std::size_t k = 0; k < out.size(); ++k) {
    out[k] += delta.segment<3>(static_cast<Eigen::Index>(3 * k));
    out[k].z() = models::wrap_angle(out[k].z());
  }
  return out;
}

/// Levenberg–Marquardt from `x` with the pairs `used`: Gauss–Newton steps (λ = 0) while they lower the
/// cost, damped by λ·diag(H) when one does not. Converged once an accepted step moves nothing by more
/// than kSmootherStepTolerance.
struct LmResult {
  int iterations = 0;
  bool converged = false;
};
/// One accepted step: the damped system solved until the cost does not rise (λ adapted in place); false if
/// no damping lowers it.
bool damped_step(const WeightedProblem& w, std::vector<Pose>& x, const std::vector<bool>& used,
                 const NormalEquations& normal, const SmootherMatrix& H, SmootherFactor& factor,
                 double& lambda, double& largest_move) {
  for (int attempt = 0; attempt < kSmootherDampingTries; ++attempt) {
    SmootherMatrix damped = H;
    if (lambda > 0.0) damped.diagonal() += lambda * H.diagonal();
    factor.factorize(damped);
    if (factor.info() == Eigen::Success) {
      const VecX delta = factor.solve(normal.b);
      std::vector<Pose> candidate = moved(x, delta);
      if (delta.allFinite() && cost_at(w, candidate, used) <= normal.cost * (1.0 + 1e-12)) {
        x = std::move(candidate);
        lambda = lambda < 1e-8 ? 0.0 : lambda / 10.0;
        largest_move = delta.lpNorm<Eigen::Infinity>();
        return true;
      }
    }
    lambda = lambda == 0.0 ? 1e-6 : lambda * 10.0;
  }
  return false;
}

LmResult levenberg_marquardt(const WeightedProblem& w, std::vector<Pose>& x, const std::vector<bool>& used,
                             int max_iterations) {
  LmResult result;
  SmootherFactor factor;
  double lambda = 0.0;
  NormalEquations normal = assemble_pose_system(w, x, used, true);
  SmootherMatrix H = matrix_of(w, normal);
  factor.analyzePattern(H);  // the pattern is the same at every iterate
  while (result.iterations < max_iterations) {
    double largest_move = 0.0;
    if (!damped_step(w, x, used, normal, H, factor, lambda, largest_move)) break;  // stuck
    ++result.iterations;
    if (largest_move < kSmootherStepTolerance) {
      result.converged = true;
      break;
    }
    normal = assemble_pose_system(w, x, used, true);
    H = matrix_of(w, normal);
  }
  return result;
}

/// Mahalanobis distance² of pair m's residual at `x` against R̃ + J P Jᵀ (P the poses' marginals; none:
/// R̃ alone); +inf when it cannot be evaluated.
double pair_distance2(const WeightedProblem& w, const std::vector<Pose>& x,
                      const std::vector<Mat3>& marginals, std::size_t m) {
  const auto rows = range_bearing_rows(w, x, m);
  if (!rows) return std::numeric_limits<double>::infinity();
  Mat2 S = w.problem.range_bearings[m].noise;
  if (!marginals.empty()) {
    for (std::size_t a = 0; a < rows->poses; ++a)
      S += rows->J[a] * marginals[rows->pose[a]] * rows->J[a].transpose();
  }
  const Eigen::LDLT<Mat2> ldlt(S);
  return rows->r.dot(ldlt.solve(rows->r));
}

std::vector<bool> gate(const WeightedProblem& w, const std::vector<Pose>& x,
                       const std::vector<Mat3>& marginals) {
  std::vector<bool> used(w.problem.range_bearings.size(), true);
  for (std::size_t m = 0; m < used.size(); ++m) {
    const double d2 = pair_distance2(w, x, marginals, m);
    used[m] = std::isfinite(d2) && (w.problem.gate_chi2 <= 0.0 || d2 <= w.problem.gate_chi2);
  }
  return used;
}

/// Each pose's 3×3 marginal of H⁻¹ (the Gauss–Newton information at `x`); empty if H is not positive
/// definite.
std::vector<Mat3> pose_marginals(const WeightedProblem& w, const std::vector<Pose>& x,
                                 const std::vector<bool>& used) {
  const SmootherMatrix H = matrix_of(w, assemble_pose_system(w, x, used, true));
  SmootherFactor factor(H);
  if (factor.info() != Eigen::Success || !(factor.vectorD().minCoeff() > 0.0)) return {};
  const SelectedInverse z(factor, 0);
  std::vector<Mat3> marginals(w.unknowns());
  for (std::size_t k = 0; k < marginals.size(); ++k) {
    for (std::size_t i = 0; i < 3; ++i) {
      for (std::size_t j = 0; j < 3; ++j)
        marginals[k](static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) =
            z.inverse(3 * k + i, 3 * k + j);
    }
  }
  return marginals;
}

}  // namespace

OdometryResidual odometry_residual(const Pose& a, const Pose& b, const Pose& delta) {
  const double c = std::cos(a.z());
  const double s = std::sin(a.z());
  const Vec2 d = b.head<2>() - a.head<2>();
  Mat2 rotation_t;  // R(θ_a)ᵀ
  rotation_t << c, s, -s, c;
  OdometryResidual out;
  out.r << rotation_t * d - delta.head<2>(), models::wrap_angle(b.z() - a.z() - delta.z());
  out.d_a.topLeftCorner<2, 2>() = -rotation_t;
  out.d_a.block<2, 1>(0, 2) << -s * d.x() + c * d.y(), -c * d.x() - s * d.y();
  out.d_a(2, 2) = -1.0;
  out.d_b.topLeftCorner<2, 2>() = rotation_t;
  out.d_b(2, 2) = 1.0;
  return out;
}

std::optional<RangeBearingResidual> range_bearing_residual(const Pose& pose, const Vec2& target,
                                                           const Vec2& measured) {
  const auto h = models::range_bearing(pose, target);
  if (!h) return std::nullopt;
  RangeBearingResidual out;
  out.r << measured.x() - h->value.x(), models::wrap_angle(measured.y() - h->value.y());
  out.d_pose = -h->d_pose;
  out.d_target = -h->d_target;
  return out;
}

PoseSmootherProblem make_pose_smoother_problem(const std::vector<Vec2>& start_m,
                                               const std::vector<double>& start_heading_rad,
                                               const estimators::KalmanFilterParams& params) {
  PoseSmootherProblem problem;
  problem.robots = static_cast<int>(start_m.size());
  problem.gate_chi2 = params.range_bearing_gate_chi2;
  const double position_variance = params.initial_std_m * params.initial_std_m;
  const double heading_variance = params.initial_heading_std_rad * params.initial_heading_std_rad;
  for (std::size_t i = 0; i < start_m.size(); ++i) {
    const double heading = i < start_heading_rad.size() ? start_heading_rad[i] : 0.0;
    problem.start.emplace_back(start_m[i].x(), start_m[i].y(), heading);
    problem.start_covariance.push_back(
        Eigen::Vector3d(position_variance, position_variance, heading_variance).asDiagonal());
  }
  return problem;
}

namespace {

/// The usable pairs of robot `robot`'s batch as factors (the filters' collect_range_bearings checks).
void add_range_bearings(PoseSmootherProblem& problem, int robot, std::int64_t step,
                        const estimators::MeasurementBatch& batch) {
  for (const auto& rb : batch.range_bearings) {
    const bool values_ok = std::isfinite(rb.range_m) && rb.range_m >= 0.0 && std::isfinite(rb.bearing_rad);
    const bool stds_ok = std::isfinite(rb.range_std_m) && rb.range_std_m > 0.0 &&
                         std::isfinite(rb.bearing_std_rad) && rb.bearing_std_rad > 0.0;
    if (!values_ok || !stds_ok) continue;
    PoseRangeBearingFactor factor;
    factor.robot = robot;
    factor.step = step;
    factor.measured = Vec2(rb.range_m, rb.bearing_rad);
    factor.noise =
        Vec2(rb.range_std_m * rb.range_std_m, rb.bearing_std_rad * rb.bearing_std_rad).asDiagonal();
    if (rb.landmark) {
      if (!rb.landmark_m.allFinite() || !rb.landmark_cov.allFinite()) continue;
      const double landmark_variance = std::max(0.0, rb.landmark_cov.trace() / 2.0);
      const double range = std::max(rb.range_m, models::kMinDistanceM);
      factor.landmark_m = rb.landmark_m;
      factor.noise += Vec2(landmark_variance, landmark_variance / (range * range)).asDiagonal();
    } else {
      if (rb.peer < 0 || rb.peer >= problem.robots || rb.peer == robot) continue;
      factor.peer = rb.peer;
    }
    problem.range_bearings.push_back(factor);
  }
}

}  // namespace

void add_pose_smoother_step(PoseSmootherProblem& problem, std::int64_t step,
                            const std::vector<estimators::MeasurementBatch>& batches,
                            const estimators::KalmanFilterParams& params) {
  problem.steps = std::max(problem.steps, step + 1);
  for (int robot = 0; robot < problem.robots; ++robot) {
    const auto k = static_cast<std::size_t>(robot);
    const estimators::MeasurementBatch* batch = k < batches.size() ? &batches[k] : nullptr;
    if (step == 0) {
      // The filters predict at step 0 too: the prior moves (and widens) before the first update.
      const auto prop = estimators::propagate_pose(problem.start[k], batch, params);
      problem.start[k] = prop.pose;
      problem.start_covariance[k] = prop.F * problem.start_covariance[k] * prop.F.transpose() + prop.Q;
    } else {
      // The unicycle commutes with rigid motions: propagating from the origin gives the step's relative
      // pose and its noise in the frame of the pose at step − 1 (pose_smoother.hpp).
      const auto prop = estimators::propagate_pose(Pose::Zero(), batch, params);
      problem.odometry.push_back({robot, step, prop.pose, prop.Q});
    }
    if (batch != nullptr) add_range_bearings(problem, robot, step, *batch);
  }
}

PoseSmootherSolution solve_pose_smoother(const PoseSmootherProblem& problem, const std::vector<Pose>& initial,
                                         const std::vector<Mat3>& initial_marginals,
                                         const PoseSmootherOptions& options) {
  const WeightedProblem weighted(problem);
  PoseSmootherSolution solution;
  solution.poses = initial;
  solution.poses.resize(weighted.unknowns(), Pose::Zero());
  std::vector<bool> used = gate(weighted, solution.poses, initial_marginals);
  while (solution.gating_rounds < std::max(1, options.max_gating_rounds)) {
    ++solution.gating_rounds;
    const LmResult lm = levenberg_marquardt(weighted, solution.poses, used, options.max_iterations);
    solution.iterations += lm.iterations;
    solution.converged = lm.converged;
    std::vector<bool> regated = gate(weighted, solution.poses, {});
    if (regated == used) break;
    if (solution.gating_rounds == options.max_gating_rounds) break;  // keep the set the poses solve
    used = std::move(regated);
  }
  solution.used = used;
  solution.range_bearings_used = static_cast<int>(std::count(used.begin(), used.end(), true));
  solution.range_bearings_gated = static_cast<int>(used.size()) - solution.range_bearings_used;
  solution.cost = cost_at(weighted, solution.poses, used);
  if (options.marginals) solution.marginals = pose_marginals(weighted, solution.poses, used);
  return solution;
}

VecX pose_smoother_gradient(const PoseSmootherProblem& problem, const std::vector<Pose>& poses,
                            const std::vector<bool>& used) {
  const WeightedProblem weighted(problem);
  return -assemble_pose_system(weighted, poses, used, false).b;
}

}  // namespace swarmloc::world
