#pragma once
// The optimum of each run's own data (docs/algorithms.md §1.3.2): the centralized batch maximum-likelihood
// solution (static truth) or MAP smoother (moving truth) of exactly the draws the algorithm's agents were
// delivered, computed by the scorer from the truth, with its covariance. A run's efficiency is its final RMSE
// over the optimum's: the bound (§1.3.1) is an average over draws, the optimum is this run's draws.
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/core/altitude.hpp"
#include "swarmloc/estimators/messages.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::world {

// ---- The sparse least-squares problem and its solver ----

/// ‖x_a − x_b‖ observed as `mean_range_m` with information `information` (the sufficient statistic of any
/// number of draws of one edge: Σ 1/σ² and the information-weighted mean). b < 0: x_b is `known_b`. D = 2
/// (planar) or 3 (a 3-D world's (x, y, z)).
template <int D>
struct OptimumRangeFactorOf {
  int a = 0;
  int b = -1;
  Eigen::Matrix<double, D, 1> known_b = Eigen::Matrix<double, D, 1>::Zero();
  double information = 0.0;
  double mean_range_m = 0.0;
};
using OptimumRangeFactor = OptimumRangeFactorOf<2>;
using OptimumRangeFactor3 = OptimumRangeFactorOf<3>;

/// b < 0: x_a ~ N(value, information⁻¹) (an anchor's fixes, a prior); else x_b − x_a ~ N(value,
/// information⁻¹) (a random-walk step, value 0).
template <int D>
struct OptimumLinearFactorOf {
  int a = 0;
  int b = -1;
  Eigen::Matrix<double, D, 1> value = Eigen::Matrix<double, D, 1>::Zero();
  Eigen::Matrix<double, D, D> information = Eigen::Matrix<double, D, D>::Zero();
};
using OptimumLinearFactor = OptimumLinearFactorOf<2>;
using OptimumLinearFactor3 = OptimumLinearFactorOf<3>;

/// Unknown D-blocks (one agent at one step), the point each starts from, and the factors over them.
template <int D>
struct OptimumProblemOf {
  std::vector<Eigen::Matrix<double, D, 1>> start;
  std::vector<OptimumRangeFactorOf<D>> ranges;
  std::vector<OptimumLinearFactorOf<D>> linear;
  /// The blocks' order is a good elimination order (a trajectory numbered step by step): factor in it
  /// instead of an AMD ordering.
  bool keep_order = false;
  /// The covariance is wanted for blocks from this one on (the others are left zero): with keep_order,
  /// a trajectory's last step costs a few columns of the recursion instead of all of them.
  std::size_t marginals_from = 0;
};
using OptimumProblem = OptimumProblemOf<2>;
using OptimumProblem3 = OptimumProblemOf<3>;

template <int D>
struct OptimumSolutionOf {
  std::vector<Eigen::Matrix<double, D, 1>> x;           ///< one per block
  std::vector<Eigen::Matrix<double, D, D>> covariance;  ///< each block's marginal of the inverse information
                                                        ///< (if asked; zero before problem.marginals_from)
  int iterations = 0;      ///< Gauss–Newton / Levenberg–Marquardt steps taken
  bool converged = false;  ///< the last step moved no block by more than ~1e-10 m
  /// The information is singular at the start (the truth) too: the data do not localize every block
  /// (not localizable; the solution is arbitrary along the singular directions).
  bool singular = false;
  /// The information is singular at the solution but not at the start: a degenerate ML (e.g. an agent with
  /// two ranges whose circles do not meet lands on the line between their centres). The solution stands;
  /// there is no covariance.
  bool singular_at_solution = false;
  double cost = 0.0;  ///< Σ weighted squared residuals (up to the draws' constant)
};
using OptimumSolution = OptimumSolutionOf<2>;
using OptimumSolution3 = OptimumSolutionOf<3>;

/// Levenberg–Marquardt on Newton's Hessian from problem.start, on the sparse normal equations (Eigen's
/// SimplicialLDLT, AMD ordering unless keep_order), and, if `covariance`, every block's D×D marginal of the
/// inverse Fisher (Gauss–Newton) information at the solution by selected inversion of its factor
/// (Takahashi's recursion on the factor's pattern: never the dense inverse).
OptimumSolution solve_optimum_problem(const OptimumProblem& problem, bool covariance);
OptimumSolution3 solve_optimum_problem(const OptimumProblem3& problem, bool covariance);

// ---- The run's optimum ----

enum class OptimumKind {
  kBatchMl,      ///< static truth: the ML of every draw up to the step (no prior)
  kMapSmoother,  ///< moving truth: the MAP of the trajectory up to the step, read at the step
  kNone,
};
std::string_view to_string(OptimumKind kind);

/// The optimum at one world step.
struct OptimumPoint {
  std::int64_t step = 0;
  double rmse_m = std::numeric_limits<double>::quiet_NaN();  ///< over the world's non-anchor agents
  /// Mean eᵀP⁻¹e over the same agents: 2 degrees of freedom each, 3 in a 3-D world.
  double nees = std::numeric_limits<double>::quiet_NaN();
  /// The information is singular at the solution (a degenerate ML): rmse_m stands, nees is NaN.
  bool singular_at_solution = false;
  /// False: the information is singular at the truth, the data do not localize every agent (rmse_m NaN).
  bool localizable = true;
  int iterations = 0;
  bool converged = false;
  /// Solved from the run's own final estimates as well as from the truth, and that solution fits the data at
  /// least as well (a static world's last step; docs/algorithms.md §1.3.2): the data prefer the estimate's
  /// basin, or cannot tell the two apart.
  bool from_estimates = false;
};

struct RunOptimum {
  OptimumKind kind = OptimumKind::kNone;
  config::RangeDraws draws = config::RangeDraws::kAllDraws;
  config::AnchorData anchors = config::AnchorData::kKnown;
  std::string reason;                ///< kind kNone: why there is none
  std::vector<OptimumPoint> points;  ///< the solved steps, ascending
  std::int64_t interval = 1;         ///< a point every `interval` steps, and at the last step
  /// Each agent's optimum at the last step (once solved as final): position, covariance (zero for a known
  /// anchor) and the truth it is scored against, and whether the agent is an unknown of the problem.
  std::vector<Vec2> final_position;
  std::vector<Mat2> final_covariance;
  std::vector<Vec2> final_truth;
  std::vector<bool> final_in_state;
  /// A 3-D world only (empty in a planar one): each agent's z with the z row of its (x, y, z) covariance,
  /// and its true z; the planar parts are in final_position, final_covariance and final_truth.
  std::vector<Altitude> final_altitude;
  std::vector<double> final_truth_z;
  double observe_cpu_s = 0.0;  ///< CPU time taking the batches in (the calling thread's)
  double solve_cpu_s = 0.0;    ///< CPU time solving
  /// The point at `step`, or nullptr.
  [[nodiscard]] const OptimumPoint* at(std::int64_t step) const;
};

/// The optimum in full, at the last observed step (for tests and tools).
struct OptimumEstimate {
  std::int64_t step = -1;
  std::vector<Vec2> position;    ///< per agent; a known anchor's known position
  std::vector<Mat2> covariance;  ///< per agent; zero for a known anchor
  std::vector<bool> in_state;    ///< the agent is an unknown of the problem
  std::vector<Vec2> truth;       ///< per agent, at the step
  /// A 3-D world only (empty in a planar one): per agent its z and the z row of its covariance (a known
  /// anchor: its true z, zero covariance), and its true z.
  std::vector<Altitude> altitude;
  std::vector<double> truth_z;
  OptimumPoint point;
  bool solved = false;  ///< false: kind kNone, nothing observed, or not localizable
  double cost = 0.0;    ///< Σ weighted squared residuals at the solution
};

/// Takes each world step's batches as the runner generates them (every runtime delivers every batch; loss
/// drops inter-agent samples only), keeps what the algorithm's data selection uses (config::BoundSpec:
/// own draws, one per edge or all draws; known anchors or fixes), and solves at checkpoints. Static truth
/// keeps per-edge sufficient statistics (O(edges), independent of the steps); moving truth keeps every
/// step's. The scorer's start is the truth; the data are only the batches.
class OptimumAccumulator {
 public:
  /// Decides the kind from the scenario (kNone with the reason when not covered) at world step 0.
  /// `checkpoints`: about this many solved steps over the run, the last step always (0: for static truth 25,
  /// fewer beyond 2000 unknown agents, 25·2000/unknowns; 5 for moving truth, whose every checkpoint solves
  /// the whole trajectory up to it).
  OptimumAccumulator(const World& world, const config::Scenario& scenario, int checkpoints = 0);
  ~OptimumAccumulator();
  OptimumAccumulator(OptimumAccumulator&&) noexcept;
  OptimumAccumulator& operator=(OptimumAccumulator&&) noexcept;
  OptimumAccumulator(const OptimumAccumulator&) = delete;
  OptimumAccumulator& operator=(const OptimumAccumulator&) = delete;

  /// World step `step`'s truth and every agent's batch (index = agent id), in step order; `altitude`: a 3-D
  /// world's true z per agent at the step (World::altitude; empty in a planar one).
  void observe(std::int64_t step, const std::vector<Vec2>& truth,
               const std::vector<estimators::MeasurementBatch>& batches,
               const std::vector<double>& altitude = {});
  /// Solves the checkpoints observed and not solved yet; `final`: the last observed step as well. With
  /// `estimates` (per agent, non-finite where it has none), a static world's last observed step is solved
  /// from them too and the solution that fits the data better is kept (the estimates' on a tie within
  /// rounding). A 3-D world's estimates need their z in `estimate_z` (per agent, non-finite where it has
  /// none): an agent without one starts from the truth.
  void solve_pending(bool final, const std::vector<Vec2>* estimates = nullptr,
                     const std::vector<double>* estimate_z = nullptr);
  [[nodiscard]] const RunOptimum& result() const;
  /// The optimum of every batch observed so far, with each agent's position and covariance.
  [[nodiscard]] OptimumEstimate solve_now() const;

  class Data;  ///< the kept data: static (sufficient statistics) or moving (every step), optimum.cpp

 private:
  std::unique_ptr<Data> data_;
  RunOptimum result_;
  std::int64_t steps_ = 1;  ///< the run's world steps (the last is always a checkpoint)
  std::int64_t last_observed_ = -1;
  std::vector<std::int64_t> pending_;  ///< checkpoints observed, not solved yet
};

}  // namespace swarmloc::world
