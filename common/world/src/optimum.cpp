// The run's optimum (docs/algorithms.md §1.3.2): which draws the algorithm's agents use, kept as they are
// generated, and the batch ML (static truth) or MAP smoother (moving truth) of them at checkpoints.
#include "swarmloc/world/optimum.hpp"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <map>

#include "optimum_data.hpp"
#include "swarmloc/world/bound.hpp"

namespace swarmloc::world {
namespace {

using enum config::RangeDraws;
using enum config::AnchorData;

constexpr double kMinRangeStd = 1e-9;  ///< m: a noiseless range keeps a finite weight (as the bound does)
/// The smoother's unknown blocks (agents × steps): beyond this its sparse factor costs seconds per
/// checkpoint.
constexpr std::int64_t kMaxSmootherBlocks = 200000;
/// Solved steps over a run (docs/algorithms.md §1.3.2): a static solve costs a few factorizations of the
/// network (N = 1000: ~10 ms); a moving one factorizes the whole trajectory up to its step.
constexpr int kStaticCheckpoints = 25;
constexpr int kMovingCheckpoints = 5;
/// Beyond this many unknown agents a static solve takes ~0.1 s of CPU per Newton step (10⁴ agents: 0.15 s
/// per factorization): the checkpoints thin out as kStaticCheckpoints · this / unknowns, down to the last
/// step.
constexpr std::int64_t kFullCheckpointAgents = 2000;
/// The kept statistics and the graph's copy cost ~40 bytes per edge; a dense world of 10⁵ agents (31 000
/// neighbours each, docs/scale.md) would need tens of gigabytes: no optimum beyond this.
constexpr std::int64_t kMaxOptimumEdges = 5000000;

/// The calling thread's CPU time: the optimum's own cost, not the time a loaded machine keeps it waiting
/// (an orchestrator sharing two cores with 200 agents measured 80× its CPU in wall time).
double thread_cpu_s() {
  timespec now{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) + 1e-9 * static_cast<double>(now.tv_nsec);
}

}  // namespace

namespace {

using Selection = OptimumSelection;
using namespace optimum_parts;

Selection make_selection(const World& world, const config::Scenario& s, const BoundData& data) {
  Selection sel;
  sel.draws = data.draws;
  sel.anchors_in_state = data.anchors == kFixes && s.noise.anchor_fix_std_m > 0.0;
  sel.shared = s.noise.shared_range_draws;
  sel.is_anchor = world.is_anchor;
  if (world.dimensions == 3) sel.altitude = world.altitude;  // step 0's z: static truth's throughout
  sel.neighbours = world.neighbours;
  sel.edge_of.resize(world.neighbours.size());
  for (std::size_t i = 0; i < world.neighbours.size(); ++i) {
    for (const AgentId j : world.neighbours[i]) {
      const auto lo = static_cast<AgentId>(i);
      if (lo < j) {
        sel.edge_of[i].push_back(static_cast<int>(sel.edges.size()));
        sel.edges.emplace_back(lo, j);
      } else {
        sel.edge_of[i].push_back(-1);  // filled from j's side below
      }
    }
  }
  for (std::size_t i = 0; i < world.neighbours.size(); ++i) {
    for (std::size_t k = 0; k < world.neighbours[i].size(); ++k) {
      const AgentId j = world.neighbours[i][k];
      if (j < static_cast<AgentId>(i)) sel.edge_of[i][k] = sel.edge(j, static_cast<AgentId>(i));
    }
  }
  return sel;
}

/// Both starts reached one solution: within 100 times the solver's stopping step (10⁻⁷ of the largest
/// coordinate, at least of 1 m), far below any range noise or mirror distance.
bool same_solution(const OptimumEstimate& a, const OptimumEstimate& b) {
  double scale = 1.0;
  for (const Vec2& x : a.position) scale = std::max(scale, x.cwiseAbs().maxCoeff());
  for (const Altitude& z : a.altitude) scale = std::max(scale, std::abs(z.z_m));
  const double tolerance = 1e-5 * scale;
  for (std::size_t i = 0; i < a.position.size(); ++i) {
    if (!a.altitude.empty()) {
      const Vec3 difference = join(a.position[i] - b.position[i], a.altitude[i].z_m - b.altitude[i].z_m);
      if (difference.norm() > tolerance) return false;
    } else if ((a.position[i] - b.position[i]).norm() > tolerance) {
      return false;
    }
  }
  return true;
}

}  // namespace

namespace optimum_parts {

void add_ranges(const OptimumSelection& sel, const std::vector<estimators::MeasurementBatch>& batches,
                std::vector<EdgeStat>& stats) {
  for (std::size_t i = 0; i < batches.size() && i < sel.is_anchor.size(); ++i) {
    const auto agent = static_cast<AgentId>(i);
    for (const auto& range : batches[i].ranges) {
      if (!sel.uses(agent, range.peer)) continue;
      const int e = sel.edge(agent, range.peer);
      if (e < 0) continue;
      const double std_m = std::max(kMinRangeStd, range.std_m);
      const double w = 1.0 / (std_m * std_m);
      stats[static_cast<std::size_t>(e)].information += w;
      stats[static_cast<std::size_t>(e)].weighted += w * range.range_m;
    }
  }
}

void add_fixes(const OptimumSelection& sel, const std::vector<estimators::MeasurementBatch>& batches,
               std::vector<FixStat>& fixes) {
  if (!sel.anchors_in_state) return;
  for (std::size_t i = 0; i < batches.size() && i < fixes.size(); ++i) {
    const auto& fix = batches[i].fix;
    if (!sel.is_anchor[i] || !fix || !(fix->covariance.determinant() > 0.0)) continue;
    const Mat2 information = fix->covariance.inverse();
    fixes[i].information += information;
    fixes[i].weighted += information * fix->position_m;
    if (!sel.altitude.empty() && fix->z_m) {
      fixes[i].z_information += 1.0 / fix->covariance(0, 0);
      fixes[i].z_weighted += *fix->z_m / fix->covariance(0, 0);
    }
  }
}

OptimumPoint score_point(std::int64_t step, const OptimumSelection& sel, const std::vector<Vec2>& truth,
                         const OptimumEstimate& estimate, bool singular, bool covariance) {
  OptimumPoint point;
  point.step = step;
  point.localizable = !singular;
  double squared = 0.0;
  double nees = 0.0;
  int scored = 0;
  const bool spatial = !estimate.altitude.empty();
  for (std::size_t i = 0; i < truth.size(); ++i) {
    if (sel.is_anchor[i]) continue;
    if (spatial) {  // a 3-D world: the error in space, a NEES of 3 degrees of freedom
      const Vec3 error =
          join(estimate.position[i], estimate.altitude[i].z_m) - join(truth[i], estimate.truth_z[i]);
      squared += error.squaredNorm();
      if (covariance)
        nees += error.dot(join(estimate.covariance[i], estimate.altitude[i]).ldlt().solve(error));
      ++scored;
      continue;
    }
    const Vec2 error = estimate.position[i] - truth[i];
    squared += error.squaredNorm();
    if (covariance) nees += error.dot(estimate.covariance[i].ldlt().solve(error));
    ++scored;
  }
  if (scored > 0 && !singular) point.rmse_m = std::sqrt(squared / scored);
  if (scored > 0 && covariance) point.nees = nees / scored;
  return point;
}

template <int D>
OptimumEstimate estimate_of(std::int64_t step, const OptimumSelection& sel, const std::vector<Vec2>& truth,
                            const std::vector<double>& truth_z, const std::vector<int>& block,
                            const OptimumSolutionOf<D>& solution) {
  const std::size_t n = truth.size();
  OptimumEstimate estimate;
  estimate.step = step;
  estimate.solved = !solution.singular;
  estimate.cost = solution.cost;
  estimate.position = truth;
  estimate.truth = truth;
  estimate.covariance.assign(n, Mat2::Zero());
  estimate.in_state.assign(n, false);
  if constexpr (D == 3) {
    estimate.truth_z = truth_z;
    for (std::size_t i = 0; i < n; ++i) estimate.altitude.push_back(Altitude{truth_z[i]});
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (block[i] < 0) continue;
    const auto b = static_cast<std::size_t>(block[i]);
    estimate.in_state[i] = true;
    if constexpr (D == 2) {
      estimate.position[i] = solution.x[b];
      if (!solution.covariance.empty()) estimate.covariance[i] = solution.covariance[b];
    } else {
      const Mat3 covariance = solution.covariance.empty() ? Mat3::Zero() : solution.covariance[b];
      estimate.position[i] = solution.x[b].template head<2>();
      estimate.covariance[i] = covariance.topLeftCorner<2, 2>();
      estimate.altitude[i] = altitude_of(solution.x[b], covariance);
    }
  }
  estimate.point = score_point(step, sel, truth, estimate, solution.singular, !solution.covariance.empty());
  estimate.point.iterations = solution.iterations;
  estimate.point.converged = solution.converged;
  estimate.point.singular_at_solution = solution.singular_at_solution;
  return estimate;
}

template OptimumEstimate estimate_of<2>(std::int64_t, const OptimumSelection&, const std::vector<Vec2>&,
                                        const std::vector<double>&, const std::vector<int>&,
                                        const OptimumSolutionOf<2>&);
template OptimumEstimate estimate_of<3>(std::int64_t, const OptimumSelection&, const std::vector<Vec2>&,
                                        const std::vector<double>&, const std::vector<int>&,
                                        const OptimumSolutionOf<3>&);

}  // namespace optimum_parts

namespace {

/// Static truth: per-edge sufficient statistics, copied at checkpoints.
class StaticData final : public OptimumAccumulator::Data {
 public:
  StaticData(Selection selection, bool once)
      : Data(std::move(selection)),
        once_(once),
        current_{std::vector<EdgeStat>(sel_.edges.size()), std::vector<FixStat>(sel_.is_anchor.size()), {}} {}

  void observe(std::int64_t step, const std::vector<Vec2>& truth, const std::vector<double>& /*altitude*/,
               const std::vector<estimators::MeasurementBatch>& batches) override {
    // Static truth: z is the selection's. noise.draw = once repeats step 0's draws bit for bit: one draw, not
    // many.
    if (!once_ || step == 0) {
      add_ranges(sel_, batches, current_.edges);
      add_fixes(sel_, batches, current_.fixes);
    }
    current_.truth = truth;
    last_step_ = step;
  }

  void checkpoint(std::int64_t step) override { kept_[step] = current_; }

  [[nodiscard]] OptimumEstimate solve(std::int64_t step, const std::vector<Vec2>* estimates,
                                      const std::vector<double>* estimate_z) const override {
    const auto it = kept_.find(step);
    if (it == kept_.end() && step != last_step_) return {};
    const Snapshot& snap = it != kept_.end() ? it->second : current_;
    return sel_.altitude.empty() ? solve_from<2>(step, snap, estimates, estimate_z)
                                 : solve_from<3>(step, snap, estimates, estimate_z);
  }

  void release(std::int64_t step) override { kept_.erase(step); }

 private:
  struct Snapshot {
    std::vector<EdgeStat> edges;
    std::vector<FixStat> fixes;
    std::vector<Vec2> truth;
  };
  template <int D>
  using Point = Eigen::Matrix<double, D, 1>;

  /// The optimum from the truth and, with `estimates`, from them: the one that fits the data better.
  template <int D>
  OptimumEstimate solve_from(std::int64_t step, const Snapshot& snap, const std::vector<Vec2>* estimates,
                             const std::vector<double>* estimate_z) const {
    std::vector<Point<D>> truth;
    truth.reserve(snap.truth.size());
    for (std::size_t i = 0; i < snap.truth.size(); ++i)
      truth.push_back(optimum_point_of<D>(snap.truth[i], sel_.altitude, i));
    OptimumEstimate from_truth = solve_snapshot<D>(step, snap, truth);
    if (estimates == nullptr || estimates->size() != snap.truth.size()) return from_truth;
    std::vector<Point<D>> start = truth;
    for (std::size_t i = 0; i < start.size(); ++i) {
      if (!(*estimates)[i].allFinite()) continue;
      if constexpr (D == 2) {
        start[i] = (*estimates)[i];
      } else if (estimate_z != nullptr && estimate_z->size() == start.size() &&
                 std::isfinite((*estimate_z)[i])) {
        start[i] = join((*estimates)[i], (*estimate_z)[i]);  // an estimate without its z is no 3-D start
      }
    }
    OptimumEstimate from_estimates = solve_snapshot<D>(step, snap, start);
    // Within rounding the two fit equally (a mirror image the data cannot tell apart): both are the ML.
    const double tie = 1e-9 * std::max(1.0, from_truth.cost);
    if (!from_estimates.solved || from_estimates.cost > from_truth.cost + tie ||
        same_solution(from_truth, from_estimates))
      return from_truth;
    from_estimates.point.from_estimates = true;
    return from_estimates;
  }

  /// The problem of one snapshot: an unknown per non-anchor (and per anchor with fixes), from `start`; D = 3
  /// in a 3-D world.
  template <int D>
  OptimumEstimate solve_snapshot(std::int64_t step, const Snapshot& snap,
                                 const std::vector<Point<D>>& start) const {
    const std::size_t n = snap.truth.size();
    std::vector<int> block(n, -1);
    OptimumProblemOf<D> problem;
    for (std::size_t i = 0; i < n; ++i) {
      if (sel_.is_anchor[i] && !sel_.anchors_in_state) continue;
      block[i] = static_cast<int>(problem.start.size());
      problem.start.push_back(start[i]);
    }
    add_range_factors<D>(snap, block, problem);
    for (std::size_t i = 0; i < n; ++i) {
      if (block[i] >= 0 && informs<D>(snap.fixes[i]))
        problem.linear.push_back(fix_factor<D>(block[i], snap.fixes[i]));
    }
    return estimate_of<D>(step, sel_, snap.truth, sel_.altitude, block, solve_optimum_problem(problem, true));
  }

  template <int D>
  void add_range_factors(const Snapshot& snap, const std::vector<int>& block,
                         OptimumProblemOf<D>& problem) const {
    for (std::size_t e = 0; e < sel_.edges.size(); ++e) {
      const EdgeStat& stat = snap.edges[e];
      if (!(stat.information > 0.0)) continue;
      auto [lo, hi] = sel_.edges[e];
      if (block[static_cast<std::size_t>(lo)] < 0) std::swap(lo, hi);  // the unknown end first
      const int a = block[static_cast<std::size_t>(lo)];
      if (a < 0) continue;  // two known anchors: no unknown
      const int b = block[static_cast<std::size_t>(hi)];
      const auto known = static_cast<std::size_t>(hi);
      problem.ranges.push_back({a, b, optimum_point_of<D>(snap.truth[known], sel_.altitude, known),
                                stat.information, stat.weighted / stat.information});
    }
  }

  bool once_ = false;
  Snapshot current_;
  std::int64_t last_step_ = -1;
  std::map<std::int64_t, Snapshot> kept_;
};

/// The steps the run will observe (a recorded world holds its own number).
std::int64_t run_steps(const World& world, const config::Scenario& s) {
  return world.recorded ? std::min<std::int64_t>(s.run.steps, world.recorded->steps()) : s.run.steps;
}

/// Why `s` has no optimum, or empty if it has one (docs/algorithms.md §1.3.2).
std::string none_reason(const World& world, const config::Scenario& s, const BoundData& data) {
  if (s.world.source == config::WorldSource::kMrclam)
    return "real data (world.source = mrclam): its noise is not a known model";
  if (data.model == BoundModel::kNone) return std::string(data.none_reason);
  if (data.model != BoundModel::kRanges)
    return "relative positions, reflected paths and target readings: no optimum implemented (ranges only)";
  std::int64_t edges = 0;
  for (const auto& list : world.neighbours) edges += static_cast<std::int64_t>(list.size());
  if (edges / 2 > kMaxOptimumEdges)
    return "more than " + std::to_string(kMaxOptimumEdges) + " edges: the optimum is not computed";
  if (!truth_moves(s)) return {};
  if (s.noise.draw == config::NoiseDraw::kOnce)
    return "moving truth with noise.draw = once (repeated draws): no optimum implemented";
  const std::int64_t moving = world.size() - world.anchor_count();
  if (moving * run_steps(world, s) > kMaxSmootherBlocks)
    return "moving truth: the smoother's agents x steps exceed " + std::to_string(kMaxSmootherBlocks);
  return {};
}

}  // namespace

std::string_view to_string(OptimumKind kind) {
  switch (kind) {
    case OptimumKind::kBatchMl:
      return "batch_ml";
    case OptimumKind::kMapSmoother:
      return "map_smoother";
    case OptimumKind::kNone:
      break;
  }
  return "none";
}

const OptimumPoint* RunOptimum::at(std::int64_t step) const {
  const auto it = std::lower_bound(points.begin(), points.end(), step,
                                   [](const OptimumPoint& p, std::int64_t s) { return p.step < s; });
  return it != points.end() && it->step == step ? &*it : nullptr;
}

OptimumAccumulator::OptimumAccumulator(const World& world, const config::Scenario& s, int checkpoints) {
  const BoundData data = bound_data(s.algorithm.name);
  result_.draws = data.draws;
  result_.anchors = data.anchors;
  if (checkpoints <= 0) {
    const std::int64_t unknowns = world.size() - world.anchor_count();
    checkpoints = truth_moves(s)
                      ? kMovingCheckpoints
                      : static_cast<int>(std::clamp<std::int64_t>(
                            kStaticCheckpoints * kFullCheckpointAgents / std::max<std::int64_t>(1, unknowns),
                            1, kStaticCheckpoints));
  }
  const std::int64_t steps = std::max<std::int64_t>(1, run_steps(world, s));
  result_.interval = std::max<std::int64_t>(1, (steps + checkpoints - 1) / std::max(1, checkpoints));
  steps_ = steps;
  result_.reason = none_reason(world, s, data);
  if (!result_.reason.empty()) return;
  Selection selection = make_selection(world, s, data);
  if (truth_moves(s)) {
    result_.kind = OptimumKind::kMapSmoother;
    data_ = make_moving_data(std::move(selection), world, s);
  } else {
    result_.kind = OptimumKind::kBatchMl;
    data_ = std::make_unique<StaticData>(std::move(selection), s.noise.draw == config::NoiseDraw::kOnce);
  }
}

OptimumAccumulator::~OptimumAccumulator() = default;
OptimumAccumulator::OptimumAccumulator(OptimumAccumulator&&) noexcept = default;
OptimumAccumulator& OptimumAccumulator::operator=(OptimumAccumulator&&) noexcept = default;

void OptimumAccumulator::observe(std::int64_t step, const std::vector<Vec2>& truth,
                                 const std::vector<estimators::MeasurementBatch>& batches,
                                 const std::vector<double>& altitude) {
  if (!data_) return;
  const double started = thread_cpu_s();
  data_->observe(step, truth, altitude, batches);
  last_observed_ = step;
  if ((step + 1) % result_.interval == 0 || step + 1 == steps_) {
    data_->checkpoint(step);
    pending_.push_back(step);
  }
  result_.observe_cpu_s += thread_cpu_s() - started;
}

void OptimumAccumulator::solve_pending(bool final, const std::vector<Vec2>* estimates,
                                       const std::vector<double>* estimate_z) {
  if (!data_) return;
  const double started = thread_cpu_s();
  const std::int64_t solved_to = result_.points.empty() ? -1 : result_.points.back().step;
  if (final && last_observed_ > solved_to &&
      std::find(pending_.begin(), pending_.end(), last_observed_) == pending_.end())
    pending_.push_back(last_observed_);
  for (const std::int64_t step : pending_) {
    const bool last = final && step == last_observed_;
    const OptimumEstimate estimate =
        data_->solve(step, last ? estimates : nullptr, last ? estimate_z : nullptr);
    data_->release(step);
    if (estimate.step >= 0) result_.points.push_back(estimate.point);
    if (final && step == last_observed_ && estimate.solved) {
      result_.final_position = estimate.position;
      result_.final_covariance = estimate.covariance;
      result_.final_truth = estimate.truth;
      result_.final_in_state = estimate.in_state;
      result_.final_altitude = estimate.altitude;
      result_.final_truth_z = estimate.truth_z;
    }
  }
  pending_.clear();
  result_.solve_cpu_s += thread_cpu_s() - started;
}

const RunOptimum& OptimumAccumulator::result() const { return result_; }

OptimumEstimate OptimumAccumulator::solve_now() const {
  if (!data_ || last_observed_ < 0) return {};
  return data_->solve(last_observed_, nullptr, nullptr);
}

}  // namespace swarmloc::world
