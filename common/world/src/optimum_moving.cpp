// The optimum of a moving world's data (docs/algorithms.md §1.3.2): every step's selected draws, and the MAP
// of the trajectory up to a step under the world's random walk, in the plane or in space.
#include <algorithm>
#include <utility>

#include "optimum_data.hpp"
#include "swarmloc/world/bound.hpp"

namespace swarmloc::world::optimum_parts {
namespace {

template <int D>
using Point = Eigen::Matrix<double, D, 1>;

/// One step's selected data of a moving world.
struct StepData {
  std::vector<std::pair<int, EdgeStat>> edges;  ///< (edge, its draws this step)
  std::vector<std::pair<int, FixStat>> fixes;   ///< (anchor, its fix this step)
  std::vector<Vec2> truth;
  std::vector<double> altitude;  ///< a 3-D world's true z (empty in a planar one)
};

/// Moving truth in D dimensions: every step's data, and the MAP of the trajectory up to a step.
template <int D>
class MovingData final : public OptimumAccumulator::Data {
 public:
  MovingData(OptimumSelection selection, const World& world, const config::Scenario& s)
      : Data(std::move(selection)),
        initial_guess_(world.initial_guess),
        initial_altitude_(world.initial_altitude),
        prior_variance_(start_prior_variance(s)),
        motion_variance_(s.world.motion_std_m * s.world.motion_std_m),
        scratch_(sel_.edges.size()) {}

  void observe(std::int64_t /*step*/, const std::vector<Vec2>& truth, const std::vector<double>& altitude,
               const std::vector<estimators::MeasurementBatch>& batches) override {
    StepData data;
    data.truth = truth;
    if constexpr (D == 3) data.altitude = altitude;
    std::fill(scratch_.begin(), scratch_.end(), EdgeStat{});
    add_ranges(sel_, batches, scratch_);
    for (std::size_t e = 0; e < scratch_.size(); ++e) {
      if (scratch_[e].information > 0.0) data.edges.emplace_back(static_cast<int>(e), scratch_[e]);
    }
    std::vector<FixStat> fixes(sel_.anchors_in_state ? sel_.is_anchor.size() : 0);
    add_fixes(sel_, batches, fixes);
    for (std::size_t i = 0; i < fixes.size(); ++i) {
      if (informs<D>(fixes[i])) data.fixes.emplace_back(static_cast<int>(i), fixes[i]);
    }
    steps_.push_back(std::move(data));
  }

  void checkpoint(std::int64_t /*step*/) override {}  // every step is kept

  [[nodiscard]] OptimumEstimate solve(std::int64_t step, const std::vector<Vec2>* estimates,
                                      const std::vector<double>* estimate_z) const override;

 private:
  /// Block indices: non-anchor i at step k, k·moving + slot(i); an anchor with fixes, one block after them.
  struct Layout {
    std::vector<int> slot;    ///< per agent: its index among the moving agents, or −1
    std::vector<int> anchor;  ///< per agent: its block if it is a static unknown (anchor with fixes), or −1
    int moving = 0;
    [[nodiscard]] int at(std::size_t agent, std::size_t step) const {
      if (anchor[agent] >= 0) return anchor[agent];
      return slot[agent] < 0 ? -1 : static_cast<int>(step) * moving + slot[agent];
    }
  };

  /// Agent i's true point at step k (with its z in space).
  [[nodiscard]] Point<D> truth_at(std::size_t k, std::size_t i) const {
    return optimum_point_of<D>(steps_[k].truth[i], steps_[k].altitude, i);
  }
  Layout layout(std::size_t steps, OptimumProblemOf<D>& problem) const;
  void add_step_factors(std::size_t k, const Layout& layout, OptimumProblemOf<D>& problem) const;

  std::vector<Vec2> initial_guess_;
  std::vector<double> initial_altitude_;  ///< a 3-D world's initial z (anchors: the truth's)
  double prior_variance_ = 1.0;
  double motion_variance_ = 0.0;
  std::vector<EdgeStat> scratch_;
  std::vector<StepData> steps_;
  /// The last solve's blocks and its steps: a later checkpoint starts its earlier steps there (the
  /// trajectory up to the previous checkpoint is nearly solved already), its new steps from the truth.
  mutable std::vector<Point<D>> warm_;
  mutable std::size_t warm_steps_ = 0;
};

template <int D>
typename MovingData<D>::Layout MovingData<D>::layout(std::size_t steps, OptimumProblemOf<D>& problem) const {
  const std::size_t n = sel_.is_anchor.size();
  Layout out;
  out.slot.assign(n, -1);
  out.anchor.assign(n, -1);
  for (std::size_t i = 0; i < n; ++i) {
    if (!sel_.is_anchor[i]) out.slot[i] = out.moving++;
  }
  const auto moving = static_cast<std::size_t>(out.moving);
  const std::size_t warm = warm_steps_ <= steps ? warm_steps_ : 0;
  problem.start.resize(moving * steps);
  for (std::size_t k = 0; k < steps; ++k) {
    for (std::size_t i = 0; i < n; ++i) {
      const auto b = static_cast<std::size_t>(out.at(i, k));
      if (out.slot[i] >= 0) problem.start[b] = k < warm ? warm_[b] : truth_at(k, i);
    }
  }
  std::size_t anchors = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!sel_.is_anchor[i] || !sel_.anchors_in_state) continue;
    out.anchor[i] = static_cast<int>(problem.start.size());
    // Anchors do not move (world.cpp advance_truth): one block each, after the moving ones.
    problem.start.push_back(warm > 0 ? warm_[moving * warm + anchors] : truth_at(0, i));
    ++anchors;
  }
  return out;
}

template <int D>
void MovingData<D>::add_step_factors(std::size_t k, const Layout& lay, OptimumProblemOf<D>& problem) const {
  const StepData& data = steps_[k];
  for (const auto& [e, stat] : data.edges) {
    auto [lo, hi] = sel_.edges[static_cast<std::size_t>(e)];
    if (lay.at(static_cast<std::size_t>(lo), k) < 0) std::swap(lo, hi);
    const int a = lay.at(static_cast<std::size_t>(lo), k);
    if (a < 0) continue;
    const int b = lay.at(static_cast<std::size_t>(hi), k);
    problem.ranges.push_back({a, b, truth_at(k, static_cast<std::size_t>(hi)), stat.information,
                              stat.weighted / stat.information});
  }
  for (const auto& [i, fix] : data.fixes) {
    const int a = lay.at(static_cast<std::size_t>(i), k);
    if (a >= 0) problem.linear.push_back(fix_factor<D>(a, fix));
  }
  if (k == 0) return;
  // The world's random walk (world.cpp advance_truth): x_i(k) − x_i(k−1) ~ N(0, motion_std² I), in every
  // coordinate.
  const Eigen::Matrix<double, D, D> step_information =
      Eigen::Matrix<double, D, D>::Identity() / motion_variance_;
  for (std::size_t i = 0; i < lay.slot.size(); ++i) {
    if (lay.slot[i] >= 0)
      problem.linear.push_back({lay.at(i, k - 1), lay.at(i, k), Point<D>::Zero(), step_information});
  }
}

template <int D>
OptimumEstimate MovingData<D>::solve(std::int64_t step, const std::vector<Vec2>* /*estimates*/,
                                     const std::vector<double>* /*estimate_z*/) const {
  if (step < 0 || static_cast<std::size_t>(step) >= steps_.size()) return {};
  const auto steps = static_cast<std::size_t>(step) + 1;
  OptimumProblemOf<D> problem;
  problem.keep_order = true;  // blocks step by step, the anchors' last: a band with a border
  const Layout lay = layout(steps, problem);
  // The prior of x(0) the PCRB starts from (bound.cpp): the initial guesses with their spread, for every
  // unknown (the anchors with fixes included: their guess is their position).
  const Eigen::Matrix<double, D, D> prior = Eigen::Matrix<double, D, D>::Identity() / prior_variance_;
  for (std::size_t i = 0; i < lay.slot.size(); ++i) {
    const int a = lay.at(i, 0);
    if (a >= 0)
      problem.linear.push_back({a, -1, optimum_point_of<D>(initial_guess_[i], initial_altitude_, i), prior});
  }
  problem.ranges.reserve(steps * (steps_[0].edges.size() + 1));
  problem.linear.reserve(steps * (lay.slot.size() + 1));
  for (std::size_t k = 0; k < steps; ++k) add_step_factors(k, lay, problem);
  problem.marginals_from = (steps - 1) * static_cast<std::size_t>(lay.moving);  // the last step, the anchors
  const OptimumSolutionOf<D> solution = solve_optimum_problem(problem, true);
  warm_ = solution.x;
  warm_steps_ = steps;
  const StepData& last = steps_[steps - 1];
  std::vector<int> block(last.truth.size());
  for (std::size_t i = 0; i < block.size(); ++i) block[i] = lay.at(i, steps - 1);
  return estimate_of<D>(step, sel_, last.truth, last.altitude, block, solution);
}

}  // namespace

std::unique_ptr<OptimumAccumulator::Data> make_moving_data(OptimumSelection selection, const World& world,
                                                           const config::Scenario& s) {
  if (world.dimensions == 3) return std::make_unique<MovingData<3>>(std::move(selection), world, s);
  return std::make_unique<MovingData<2>>(std::move(selection), world, s);
}

}  // namespace swarmloc::world::optimum_parts
