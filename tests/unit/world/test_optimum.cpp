// The optimum of each run's own data (docs/algorithms.md §1.3.2): the sparse solver's covariance against the
// dense inverse, the batch ML against brute force (a grid search, many restarts, and a dense solve on the raw
// draws each algorithm receives), its RMSE over many trials against the CRLB, the MAP smoother against a
// dense MAP of the raw draws and against the PCRB. What a simulated run reports:
// tests/unit/sim/test_simulated_optimum.cpp.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "linked_world.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/run/fusion_centre.hpp"
#include "swarmloc/world/bound.hpp"
#include "swarmloc/world/optimum.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::world {
namespace {

/// Every pair of `truth` within range of each other; the first `anchors` agents are anchors.
World optimum_world(std::vector<Vec2> truth, int anchors) {
  return testing::fully_linked_world(std::move(truth), anchors);
}

/// Anchors 0–3 at the corners of a 10 m square, unknowns 4–6 inside (test_bound.cpp's small world).
World square_world() {
  return optimum_world(
      {{0.0, 0.0}, {10.0, 0.0}, {10.0, 10.0}, {0.0, 10.0}, {3.0, 4.0}, {7.0, 3.0}, {5.0, 7.5}}, 4);
}

config::Scenario optimum_scenario(const std::string& algorithm, int agents, int anchors, int steps) {
  config::Scenario s;
  s.seed = 23;
  s.algorithm.name = algorithm;
  s.world.agents = agents;
  s.world.anchors = anchors;
  s.world.comm_radius_m = 100.0;
  s.noise.range_std_m = 0.1;
  s.run.steps = steps;
  return s;
}

/// Every agent's batch of every step, from the world's own generator (truth advanced for moving worlds).
std::vector<std::vector<estimators::MeasurementBatch>> all_batches(
    World& world, const config::Scenario& s, std::vector<std::vector<Vec2>>* truths = nullptr) {
  std::vector<std::vector<estimators::MeasurementBatch>> out;
  for (std::int64_t step = 0; step < s.run.steps; ++step) {
    if (step > 0) advance_truth(world, s, step);
    std::vector<estimators::MeasurementBatch> batches;
    for (AgentId i = 0; i < world.size(); ++i) batches.push_back(generate_batch(world, s, i, step));
    out.push_back(std::move(batches));
    if (truths != nullptr) truths->push_back(world.truth);
  }
  return out;
}

/// The accumulator's optimum after observing `batches` (truth `truths[k]` at step k, or the world's).
OptimumEstimate optimum_of(const World& start, const config::Scenario& s,
                           const std::vector<std::vector<estimators::MeasurementBatch>>& batches,
                           const std::vector<std::vector<Vec2>>& truths = {}) {
  OptimumAccumulator accumulator(start, s);
  for (std::size_t k = 0; k < batches.size(); ++k)
    accumulator.observe(static_cast<std::int64_t>(k), truths.empty() ? start.truth : truths[k], batches[k]);
  return accumulator.solve_now();
}

// ---- A dense reference on the raw draws (the test's own, independent of optimum.cpp) ----

/// One raw draw: ‖x_a − x_b‖ = range (a known point for b < 0), or x_a = point (b < 0, a fix or prior), or
/// x_b − x_a = point (a random-walk step); variance `variance` (per axis for the vector kinds).
struct RawTerm {
  enum Kind { kRange, kPoint, kDifference } kind = kRange;
  int a = 0;
  int b = -1;
  Vec2 point = Vec2::Zero();
  double range = 0.0;
  double variance = 1.0;
};

double raw_cost(const std::vector<RawTerm>& terms, const std::vector<Vec2>& x) {
  double cost = 0.0;
  for (const auto& t : terms) {
    const Vec2& xa = x[static_cast<std::size_t>(t.a)];
    if (t.kind == RawTerm::kRange) {
      const Vec2 other = t.b < 0 ? t.point : x[static_cast<std::size_t>(t.b)];
      const double e = t.range - (xa - other).norm();
      cost += e * e / t.variance;
    } else {
      const Vec2 e = t.kind == RawTerm::kPoint ? Vec2(t.point - xa)
                                               : Vec2(t.point - (x[static_cast<std::size_t>(t.b)] - xa));
      cost += e.squaredNorm() / t.variance;
    }
  }
  return cost;
}

/// JᵀR⁻¹J of the raw terms at x (dense).
MatX raw_information(const std::vector<RawTerm>& terms, const std::vector<Vec2>& x,
                     VecX* gradient = nullptr) {
  const auto n = static_cast<Eigen::Index>(2 * x.size());
  MatX H = MatX::Zero(n, n);
  if (gradient != nullptr) *gradient = VecX::Zero(n);
  for (const auto& t : terms) {
    VecX row = VecX::Zero(n);  // ∂(model)/∂x for each scalar row
    std::vector<std::pair<VecX, double>> rows;
    const Vec2& xa = x[static_cast<std::size_t>(t.a)];
    if (t.kind == RawTerm::kRange) {
      const Vec2 other = t.b < 0 ? t.point : x[static_cast<std::size_t>(t.b)];
      const Vec2 u = (xa - other) / (xa - other).norm();
      row.segment<2>(2 * t.a) = u;
      if (t.b >= 0) row.segment<2>(2 * t.b) = -u;
      rows.emplace_back(row, t.range - (xa - other).norm());
    } else {
      const Vec2 e = t.kind == RawTerm::kPoint ? Vec2(t.point - xa)
                                               : Vec2(t.point - (x[static_cast<std::size_t>(t.b)] - xa));
      for (int axis = 0; axis < 2; ++axis) {
        VecX r = VecX::Zero(n);
        r(2 * t.a + axis) = t.kind == RawTerm::kPoint ? 1.0 : -1.0;
        if (t.kind == RawTerm::kDifference) r(2 * t.b + axis) = 1.0;
        rows.emplace_back(r, e(axis));
      }
    }
    for (const auto& [r, e] : rows) {
      H += r * r.transpose() / t.variance;
      if (gradient != nullptr) *gradient += r * e / t.variance;
    }
  }
  return H;
}

/// Dense Gauss–Newton with step halving from `x`; the local minimum.
std::vector<Vec2> dense_minimum(const std::vector<RawTerm>& terms, std::vector<Vec2> x) {
  for (int iteration = 0; iteration < 100; ++iteration) {
    VecX g;
    const MatX H = raw_information(terms, x, &g);
    const VecX dx = H.ldlt().solve(g);
    double scale = 1.0;
    const double cost = raw_cost(terms, x);
    std::vector<Vec2> trial = x;
    for (int halving = 0; halving < 40; ++halving, scale /= 2.0) {
      for (std::size_t b = 0; b < x.size(); ++b)
        trial[b] = x[b] + scale * dx.segment<2>(2 * static_cast<Eigen::Index>(b));
      if (raw_cost(terms, trial) <= cost) break;
    }
    x = trial;
    if (scale * dx.cwiseAbs().maxCoeff() < 1e-13) break;
  }
  return x;
}

/// The raw range draws of the static small worlds: unknown agents are variables 0…; `keep(i, j)` selects.
template <typename Keep>
std::vector<RawTerm> raw_ranges(const World& world,
                                const std::vector<std::vector<estimators::MeasurementBatch>>& batches,
                                const std::vector<int>& variable, Keep keep) {
  std::vector<RawTerm> terms;
  for (const auto& step : batches) {
    for (AgentId i = 0; i < world.size(); ++i) {
      for (const auto& r : step[static_cast<std::size_t>(i)].ranges) {
        if (!keep(i, r.peer)) continue;
        int a = variable[static_cast<std::size_t>(i)];
        int b = variable[static_cast<std::size_t>(r.peer)];
        AgentId known = r.peer;
        if (a < 0) std::swap(a, b), known = i;
        if (a < 0) continue;
        RawTerm t;
        t.a = a;
        t.b = b;
        t.point = world.truth[static_cast<std::size_t>(known)];
        t.range = r.range_m;
        t.variance = r.std_m * r.std_m;
        terms.push_back(t);
      }
    }
  }
  return terms;
}

std::vector<int> non_anchor_variables(const World& world) {
  std::vector<int> variable(static_cast<std::size_t>(world.size()), -1);
  int next = 0;
  for (std::size_t i = 0; i < variable.size(); ++i) {
    if (!world.is_anchor[i]) variable[i] = next++;
  }
  return variable;
}

std::vector<Vec2> truth_of_variables(const World& world, const std::vector<int>& variable) {
  std::vector<Vec2> x;
  for (std::size_t i = 0; i < variable.size(); ++i) {
    if (variable[i] >= 0) x.push_back(world.truth[i]);
  }
  return x;
}

// ---- The solver ----

TEST(OptimumSolver, MarginalCovariancesEqualTheDenseInverseOfTheInformation) {
  // Five unknowns in a chain with known points at both ends, one fix, one random-walk pair: the factor's
  // fill-in and the selected inversion's clique lookups are exercised.
  OptimumProblem p;
  p.start = {{1.0, 0.5}, {3.0, 1.5}, {5.0, -0.5}, {7.0, 1.0}, {9.0, 0.2}};
  const std::vector<Vec2> known = {{0.0, 0.0}, {10.0, 0.0}, {5.0, 6.0}};
  p.ranges = {{0, -1, known[0], 4.0, 1.1},    {0, 1, Vec2::Zero(), 2.0, 2.2}, {1, 2, Vec2::Zero(), 3.0, 2.3},
              {2, 3, Vec2::Zero(), 5.0, 2.4}, {3, 4, Vec2::Zero(), 1.5, 2.1}, {4, -1, known[1], 2.5, 1.0},
              {1, -1, known[2], 1.0, 5.0},    {3, -1, known[2], 0.7, 5.5},    {0, 2, Vec2::Zero(), 0.4, 4.0}};
  Mat2 fix_information;
  fix_information << 3.0, 0.5, 0.5, 2.0;
  p.linear = {{2, -1, {5.1, -0.4}, fix_information}, {3, 4, {2.0, -0.9}, Mat2::Identity() * 0.8}};
  const OptimumSolution solution = solve_optimum_problem(p, true);
  ASSERT_TRUE(solution.converged);
  ASSERT_FALSE(solution.singular);
  // The same information built densely, term by term, at the solution.
  std::vector<RawTerm> terms;
  for (const auto& f : p.ranges) {
    RawTerm t;
    t.a = f.a, t.b = f.b, t.point = f.known_b, t.range = f.mean_range_m, t.variance = 1.0 / f.information;
    terms.push_back(t);
  }
  MatX H = raw_information(terms, solution.x);
  H.block<2, 2>(4, 4) += fix_information;
  for (const auto& [a, b] : {std::pair{6, 6}, std::pair{8, 8}}) H.block<2, 2>(a, b) += 0.8 * Mat2::Identity();
  H.block<2, 2>(6, 8) -= 0.8 * Mat2::Identity();
  H.block<2, 2>(8, 6) -= 0.8 * Mat2::Identity();
  const MatX inverse = H.inverse();
  for (int b = 0; b < 5; ++b) {
    const Mat2 expected = inverse.block<2, 2>(2 * b, 2 * b);
    EXPECT_LT((solution.covariance[static_cast<std::size_t>(b)] - expected).norm(), 1e-10 * expected.norm())
        << "block " << b << ":\n"
        << solution.covariance[static_cast<std::size_t>(b)] << "\nexpected\n"
        << expected;
  }
}

TEST(OptimumSolver, ASingularProblemIsReportedNotSolved) {
  OptimumProblem p;  // one known point: the unknown can sit anywhere on a circle
  p.start = {{3.0, 4.0}};
  p.ranges = {{0, -1, Vec2::Zero(), 100.0, 5.0}};
  const OptimumSolution solution = solve_optimum_problem(p, true);
  EXPECT_TRUE(solution.singular);
  EXPECT_FALSE(solution.singular_at_solution);
  EXPECT_EQ(solution.iterations, 0) << "singular at the truth: not localizable, no iteration spent";
  EXPECT_TRUE(solution.covariance.empty());
}

TEST(OptimumSolver, ADegenerateMlKeepsItsSolutionWithoutACovariance) {
  // Two known points 10 m apart, both ranges 4 m: the circles do not meet, the ML is the midpoint, where
  // both range directions are collinear and the information is singular (it is not at the start).
  OptimumProblem p;
  p.start = {{5.0, 0.5}};
  p.ranges = {{0, -1, Vec2(0.0, 0.0), 100.0, 4.0}, {0, -1, Vec2(10.0, 0.0), 100.0, 4.0}};
  const OptimumSolution solution = solve_optimum_problem(p, true);
  EXPECT_FALSE(solution.singular);
  EXPECT_TRUE(solution.singular_at_solution);
  EXPECT_TRUE(solution.covariance.empty());
  EXPECT_LT((solution.x[0] - Vec2(5.0, 0.0)).norm(), 1e-6) << solution.x[0].transpose();
}

// ---- The batch ML equals brute force ----

TEST(OptimumBatchMl, OneUnknownEqualsAGridSearchOfItsDraws) {
  World world = optimum_world({{0.0, 0.0}, {10.0, 0.0}, {0.0, 10.0}, {4.0, 3.0}}, 3);
  const auto s = optimum_scenario("dml", 4, 3, 10);
  const auto batches = all_batches(world, s);
  const OptimumEstimate optimum = optimum_of(world, s, batches);
  ASSERT_TRUE(optimum.solved);
  const std::vector<int> variable = non_anchor_variables(world);
  const auto terms = raw_ranges(world, batches, variable, [](AgentId, AgentId) { return true; });
  ASSERT_EQ(terms.size(), 60U) << "both ends' draws of three edges, ten steps";
  // Coarse to fine: ±20 cm at 1 mm, then ±2 mm at 0.01 mm around the best cell.
  Vec2 best = world.truth[3];
  for (const double half_width : {0.2, 0.002}) {
    const double cell = half_width / 200.0;
    const Vec2 centre = best;
    double best_cost = std::numeric_limits<double>::infinity();
    for (int u = -200; u <= 200; ++u) {
      for (int v = -200; v <= 200; ++v) {
        const std::vector<Vec2> x = {centre + cell * Vec2(u, v)};
        const double cost = raw_cost(terms, x);
        if (cost < best_cost) best_cost = cost, best = x[0];
      }
    }
  }
  EXPECT_LT((optimum.position[3] - best).norm(), 2e-5)
      << optimum.position[3].transpose() << " vs grid " << best.transpose();
  EXPECT_GT((optimum.position[3] - world.truth[3]).norm(), 1e-4) << "the ML is not the truth it starts from";
}

/// Anchors 0 and 1 on the x axis and agent 3 at (4, 3) ranging to both: its mirror image (4, −3) fits the
/// same ranges. With `third_anchor` agent 3 also ranges to anchor 2 at (40, 0.5), 36.09 m from it and
/// 36.17 m from the mirror: the mirror stays a local minimum, but one that fits worse.
World hinge_world(bool third_anchor) {
  World world = optimum_world({{0.0, 0.0}, {10.0, 0.0}, {40.0, 0.5}, {4.0, 3.0}}, 3);
  world.neighbours = {{3}, {3}, {}, {0, 1}};
  if (third_anchor) world.neighbours = {{3}, {3}, {3}, {0, 1, 2}};
  return world;
}

RunOptimum optimum_with_estimates(World world, const std::vector<Vec2>& estimates) {
  const auto s = optimum_scenario("dml", 4, 3, 10);
  OptimumAccumulator accumulator(world, s);
  const auto batches = all_batches(world, s);
  for (std::size_t k = 0; k < batches.size(); ++k)
    accumulator.observe(static_cast<std::int64_t>(k), world.truth, batches[k]);
  accumulator.solve_pending(true, &estimates);
  return accumulator.result();
}

TEST(OptimumBatchMl, AMirrorImageTheDataCannotRuleOutIsTheOptimumWhereTheEstimateFoundIt) {
  // The two members of a mirror pair fit every range equally: both are the ML of the draws, so an estimate
  // in the mirror basin is compared with the ML there, not with the one the truth's start finds.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Vec2> mirrored = {{nan, nan}, {nan, nan}, {nan, nan}, {4.05, -2.95}};
  const RunOptimum mirror = optimum_with_estimates(hinge_world(false), mirrored);
  ASSERT_FALSE(mirror.points.empty());
  EXPECT_TRUE(mirror.points.back().from_estimates);
  EXPECT_NEAR(mirror.points.back().rmse_m, 6.0, 0.1) << "the optimum in the mirror basin, 6 m from the truth";

  // An estimate in the truth's basin reaches the same solution: the truth's start is kept.
  const RunOptimum near =
      optimum_with_estimates(hinge_world(false), {{nan, nan}, {nan, nan}, {nan, nan}, {4.05, 3.05}});
  EXPECT_FALSE(near.points.back().from_estimates);
  EXPECT_LT(near.points.back().rmse_m, 0.1);

  // A third anchor rules the mirror out: its basin fits worse, and the truth's solution stays the optimum.
  // (The estimates' start does reach a solution of its own there, so the costs decide, not the basin.)
  const RunOptimum ruled_out = optimum_with_estimates(hinge_world(true), mirrored);
  EXPECT_FALSE(ruled_out.points.back().from_estimates);
  EXPECT_LT(ruled_out.points.back().rmse_m, 0.1);
}

TEST(OptimumBatchMl, ThreeUnknownsEqualTheBestOfManyRestartsOnTheRawDraws) {
  World world = square_world();
  auto s = optimum_scenario("dml", 7, 4, 5);
  s.noise.range_std_m = 0.3;
  for (const std::uint64_t trial : {0U, 1U, 2U}) {
    world.trial = trial;
    const auto batches = all_batches(world, s);
    const OptimumEstimate optimum = optimum_of(world, s, batches);
    ASSERT_TRUE(optimum.solved);
    const std::vector<int> variable = non_anchor_variables(world);
    const auto terms = raw_ranges(world, batches, variable, [](AgentId, AgentId) { return true; });
    std::mt19937_64 rng(trial + 5);
    std::uniform_real_distribution<double> offset(-3.0, 3.0);
    std::vector<Vec2> best;
    double best_cost = std::numeric_limits<double>::infinity();
    for (int restart = 0; restart < 200; ++restart) {
      std::vector<Vec2> start = truth_of_variables(world, variable);
      for (auto& p : start) p += Vec2(offset(rng), offset(rng));
      const auto x = dense_minimum(terms, start);
      if (const double cost = raw_cost(terms, x); cost < best_cost) best_cost = cost, best = x;
    }
    for (std::size_t i = 4; i < 7; ++i)
      EXPECT_LT((optimum.position[i] - best[i - 4]).norm(), 1e-7) << "trial " << trial << " agent " << i;
  }
}

/// The ranges each algorithm's agents receive, as test_bound.cpp reads them off the code: ieif the
/// non-anchors' own batches, ekf the fusion centre's run::centralized_measurements (and the anchors' fixes),
/// dml every batch.
std::vector<RawTerm> algorithm_terms(const World& world, const config::Scenario& s,
                                     const std::vector<std::vector<estimators::MeasurementBatch>>& batches,
                                     const std::vector<int>& variable) {
  if (s.algorithm.name == "ieif") {
    return raw_ranges(world, batches, variable,
                      [&](AgentId i, AgentId) { return !world.is_anchor[static_cast<std::size_t>(i)]; });
  }
  if (s.algorithm.name == "dml")
    return raw_ranges(world, batches, variable, [](AgentId, AgentId) { return true; });
  std::vector<RawTerm> terms;
  for (const auto& step : batches) {
    std::vector<const estimators::MeasurementBatch*> pointers;
    for (const auto& b : step) pointers.push_back(&b);
    const auto measured = run::centralized_measurements(s, pointers);
    for (const auto& r : measured.ranges)
      terms.push_back({RawTerm::kRange, variable[static_cast<std::size_t>(r.i)],
                       variable[static_cast<std::size_t>(r.j)], Vec2::Zero(), r.range_m,
                       s.noise.range_std_m * s.noise.range_std_m});
    for (const auto& [agent, position] : measured.beacon_fixes)
      terms.push_back({RawTerm::kPoint, variable[static_cast<std::size_t>(agent)], -1, position, 0.0,
                       s.noise.anchor_fix_std_m * s.noise.anchor_fix_std_m});
  }
  return terms;
}

TEST(OptimumBatchMl, EachAlgorithmsOptimumIsTheMlOfTheDrawsItsAgentsReceive) {
  World world = square_world();
  for (const std::string name : {"ieif", "ekf", "dml"}) {
    auto s = optimum_scenario(name, 7, 4, 6);
    if (name == "ekf") s.noise.anchor_fix_std_m = 0.2;  // the fusion centre's anchors are in its state
    const auto batches = all_batches(world, s);
    const OptimumEstimate optimum = optimum_of(world, s, batches);
    ASSERT_TRUE(optimum.solved) << name;
    std::vector<int> variable = non_anchor_variables(world);
    if (name == "ekf") variable = {0, 1, 2, 3, 4, 5, 6};  // every agent is an unknown
    const auto terms = algorithm_terms(world, s, batches, variable);
    std::vector<Vec2> start;
    for (std::size_t i = 0; i < variable.size(); ++i) {
      if (variable[i] >= 0) start.push_back(world.truth[i]);
    }
    const auto reference = dense_minimum(terms, start);
    const MatX covariance = raw_information(terms, reference).inverse();
    for (std::size_t i = 0; i < 7; ++i) {
      const int v = variable[i];
      if (v < 0) {
        EXPECT_FALSE(optimum.in_state[i]) << name;
        continue;
      }
      EXPECT_LT((optimum.position[i] - reference[static_cast<std::size_t>(v)]).norm(), 1e-9)
          << name << " agent " << i;
      const Mat2 expected = covariance.block<2, 2>(2 * v, 2 * v);
      EXPECT_LT((optimum.covariance[i] - expected).norm(), 1e-9 * covariance.norm())
          << name << " agent " << i;
    }
  }
}

TEST(OptimumBatchMl, OverManyTrialsItsRmseIsTheAccumulatedCrlbAndItsNeesTwo) {
  constexpr int kTrials = 400;
  World world = square_world();
  for (const std::string name : {"ieif", "ekf", "dml"}) {
    const auto s = optimum_scenario(name, 7, 4, 5);
    const RunBound bound = run_bound(world, s, scenario_crlb(world, s));
    double mse = 0.0;
    double nees = 0.0;
    for (int trial = 0; trial < kTrials; ++trial) {
      world.trial = static_cast<std::uint64_t>(trial);
      const OptimumEstimate optimum = optimum_of(world, s, all_batches(world, s));
      mse += optimum.point.rmse_m * optimum.point.rmse_m / kTrials;
      nees += optimum.point.nees / kTrials;
    }
    const double ratio = std::sqrt(mse) / bound.rmse_at(s.run.steps - 1);
    EXPECT_NEAR(ratio, 1.0, 0.05) << name;
    EXPECT_NEAR(nees, 2.0, 0.25) << name;
    RecordProperty(name + "_optimum_over_bound", std::to_string(ratio));
  }
}

TEST(OptimumBatchMl, RepeatedDrawsCountOnceAndTheSelectionMatchesTheBoundsTable) {
  World world = square_world();
  auto s = optimum_scenario("dml", 7, 4, 8);
  s.noise.draw = config::NoiseDraw::kOnce;
  const auto batches = all_batches(world, s);
  const std::vector<std::vector<estimators::MeasurementBatch>> first(batches.begin(), batches.begin() + 1);
  const OptimumEstimate all = optimum_of(world, s, batches);
  const OptimumEstimate one = optimum_of(world, s, first);
  for (std::size_t i = 4; i < 7; ++i) {
    EXPECT_LT((all.position[i] - one.position[i]).norm(), 1e-12);
    EXPECT_LT((all.covariance[i] - one.covariance[i]).norm(), 1e-15) << "a repeated draw is one draw";
  }
}

// ---- The MAP smoother of a moving world ----

/// Initial guesses drawn as the world draws them for noisy_truth (the smoother's prior and the PCRB's J_0
/// assume guess − truth ~ N(0, initial_guess_std² I)), for every agent.
void draw_guesses(World& world, double std_m, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, std_m);
  for (std::size_t i = 0; i < world.truth.size(); ++i)
    world.initial_guess[i] = world.truth[i] + Vec2(gauss(rng), gauss(rng));
}

config::Scenario moving_scenario(const std::string& algorithm, int steps) {
  auto s = optimum_scenario(algorithm, 7, 4, steps);
  s.world.motion = config::Motion::kRandomWalk;
  s.world.motion_std_m = 0.3;
  s.world.initial_guess_std_m = 1.5;
  s.world.comm_radius_m = 9.0;  // edges leave and enter the range as the agents move
  s.noise.range_std_m = 0.5;
  s.noise.anchor_fix_std_m = 0.7;  // dml_track's anchors are in the state; ieif's are known
  return s;
}

/// The smoother's MAP built densely from the raw draws: variable (agent, step) for the unknowns, one per
/// anchor in the state; priors on the initial guesses, the world's random walk, every selected draw.
std::vector<RawTerm> raw_trajectory_terms(
    const World& start, const config::Scenario& s,
    const std::vector<std::vector<estimators::MeasurementBatch>>& batches,
    const std::vector<std::vector<Vec2>>& truths, bool anchors_in_state, std::vector<Vec2>& x0,
    std::vector<int>& last_step_variable) {
  const int n = start.size();
  const int steps = static_cast<int>(batches.size());
  auto variable = [&](int agent, int step) {
    if (start.is_anchor[static_cast<std::size_t>(agent)]) return anchors_in_state ? 3 * steps + agent : -1;
    return step * 3 + (agent - 4);
  };
  x0.assign(static_cast<std::size_t>(3 * steps + (anchors_in_state ? 4 : 0)), Vec2::Zero());
  for (int k = 0; k < steps; ++k) {
    for (int i = 0; i < n; ++i) {
      if (variable(i, k) >= 0)
        x0[static_cast<std::size_t>(variable(i, k))] =
            truths[static_cast<std::size_t>(k)][static_cast<std::size_t>(i)];
    }
  }
  std::vector<RawTerm> terms;
  const double prior = s.world.initial_guess_std_m * s.world.initial_guess_std_m;
  for (int i = 0; i < n; ++i) {
    if (variable(i, 0) >= 0)
      terms.push_back({RawTerm::kPoint, variable(i, 0), -1, start.initial_guess[static_cast<std::size_t>(i)],
                       0.0, prior});
  }
  const bool own_draws = s.algorithm.name == "ieif";
  for (int k = 0; k < steps; ++k) {
    for (int i = 4; i < n && k > 0; ++i)
      terms.push_back({RawTerm::kDifference, variable(i, k - 1), variable(i, k), Vec2::Zero(), 0.0,
                       s.world.motion_std_m * s.world.motion_std_m});
    for (int i = 0; i < n; ++i) {
      const auto& batch = batches[static_cast<std::size_t>(k)][static_cast<std::size_t>(i)];
      if (batch.fix && anchors_in_state)
        terms.push_back({RawTerm::kPoint, variable(i, k), -1, batch.fix->position_m, 0.0,
                         s.noise.anchor_fix_std_m * s.noise.anchor_fix_std_m});
      if (own_draws && start.is_anchor[static_cast<std::size_t>(i)]) continue;
      for (const auto& r : batch.ranges) {
        int a = variable(i, k);
        int b = variable(r.peer, k);
        AgentId known = r.peer;
        if (a < 0) std::swap(a, b), known = i;
        if (a < 0) continue;
        terms.push_back({RawTerm::kRange, a, b,
                         truths[static_cast<std::size_t>(k)][static_cast<std::size_t>(known)], r.range_m,
                         r.std_m * r.std_m});
      }
    }
  }
  last_step_variable.assign(static_cast<std::size_t>(n), -1);
  for (int i = 0; i < n; ++i) last_step_variable[static_cast<std::size_t>(i)] = variable(i, steps - 1);
  return terms;
}

TEST(OptimumSmoother, EqualsADenseMapOfTheRawDrawsPriorsAndRandomWalk) {
  for (const std::string name : {"ieif", "dml_track"}) {
    const auto s = moving_scenario(name, 8);
    World start = square_world();
    draw_guesses(start, s.world.initial_guess_std_m, 3);
    World world = start;
    std::vector<std::vector<Vec2>> truths;
    const auto batches = all_batches(world, s, &truths);
    const OptimumEstimate optimum = optimum_of(start, s, batches, truths);
    ASSERT_TRUE(optimum.solved) << name;
    std::vector<Vec2> x0;
    std::vector<int> last;
    const auto terms = raw_trajectory_terms(start, s, batches, truths, name == "dml_track", x0, last);
    const auto reference = dense_minimum(terms, x0);
    const MatX covariance = raw_information(terms, reference).inverse();
    for (std::size_t i = 4; i < 7; ++i) {
      const int v = last[i];
      EXPECT_LT((optimum.position[i] - reference[static_cast<std::size_t>(v)]).norm(), 1e-8)
          << name << " agent " << i;
      const Mat2 expected = covariance.block<2, 2>(2 * v, 2 * v);
      EXPECT_LT((optimum.covariance[i] - expected).norm(), 1e-8 * expected.norm()) << name << " agent " << i;
    }
  }
}

TEST(OptimumSmoother, OverManyTrialsItsFinalErrorIsThePosteriorCrb) {
  constexpr int kTrials = 300;
  for (const std::string name : {"ieif", "dml_track"}) {
    const auto s = moving_scenario(name, 10);
    World start = square_world();
    double mse = 0.0;
    double bound_sq = 0.0;
    double nees = 0.0;
    for (int trial = 0; trial < kTrials; ++trial) {
      start.trial = static_cast<std::uint64_t>(trial);
      draw_guesses(start, s.world.initial_guess_std_m, static_cast<std::uint64_t>(trial) + 100);
      const RunBound bound = run_bound(start, s, scenario_crlb(start, s));
      World world = start;
      std::vector<std::vector<Vec2>> truths;
      const auto batches = all_batches(world, s, &truths);
      const OptimumEstimate optimum = optimum_of(start, s, batches, truths);
      mse += optimum.point.rmse_m * optimum.point.rmse_m / kTrials;
      nees += optimum.point.nees / kTrials;
      bound_sq += bound.rmse_at(s.run.steps - 1) * bound.rmse_at(s.run.steps - 1) / kTrials;
    }
    const double ratio = std::sqrt(mse / bound_sq);
    EXPECT_NEAR(ratio, 1.0, 0.07) << name;
    EXPECT_NEAR(nees, 2.0, 0.3) << name;
    RecordProperty(name + "_smoother_over_pcrb", std::to_string(ratio));
  }
}

TEST(OptimumCheckpoints, EachEqualsTheOptimumOfTheDataUpToItsStep) {
  // Static truth keeps a copy of the sufficient statistics at each checkpoint; moving truth solves the
  // trajectory up to it (its earlier steps started from the previous checkpoint's solution).
  for (const bool moving : {false, true}) {
    const auto s = moving ? moving_scenario("dml_track", 10) : optimum_scenario("dml", 7, 4, 10);
    World start = square_world();
    draw_guesses(start, s.world.initial_guess_std_m, 7);
    World world = start;
    std::vector<std::vector<Vec2>> truths;
    const auto batches = all_batches(world, s, &truths);
    OptimumAccumulator accumulator(start, s, 5);
    for (std::size_t k = 0; k < batches.size(); ++k)
      accumulator.observe(static_cast<std::int64_t>(k), truths[k], batches[k]);
    accumulator.solve_pending(true);
    const auto& points = accumulator.result().points;
    ASSERT_EQ(points.size(), 5U) << "steps 1, 3, 5, 7, 9";
    for (const auto& point : points) {
      const auto steps = static_cast<std::ptrdiff_t>(point.step + 1);
      const std::vector<std::vector<estimators::MeasurementBatch>> prefix(batches.begin(),
                                                                          batches.begin() + steps);
      const std::vector<std::vector<Vec2>> prefix_truths(truths.begin(), truths.begin() + steps);
      const OptimumEstimate fresh = optimum_of(start, s, prefix, prefix_truths);
      EXPECT_NEAR(point.rmse_m, fresh.point.rmse_m, 1e-9 * fresh.point.rmse_m)
          << (moving ? "moving" : "static") << " step " << point.step;
      EXPECT_NEAR(point.nees, fresh.point.nees, 1e-6)
          << (moving ? "moving" : "static") << " step " << point.step;
    }
    EXPECT_NE(points.front().rmse_m, points.back().rmse_m) << "each checkpoint has its own data";
  }
}

}  // namespace
}  // namespace swarmloc::world
