// The bound and the optimum of a 3-D range world (World::dimensions == 3, docs/algorithms.md §1.3.1,
// §1.3.2): the bound against a Fisher matrix built in space by hand, the batch ML against many restarts of a
// dense Gauss–Newton on the raw draws and its covariance against the dense inverse Fisher, the optimum's
// RMSE over many draws against the CRLB with a NEES of 3, and the second start that needs the estimate's z.
// The worlds and draws are built here (σ per endpoint, as generate_batch draws them), not generated.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "linked_world.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/world/bound.hpp"
#include "swarmloc/world/optimum.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::world {
namespace {

/// A 3-D world of `points` (x, y, z), every pair in range; the first `anchors` agents are anchors.
World spatial_world(const std::vector<Vec3>& points, int anchors) {
  std::vector<Vec2> planar;
  std::vector<double> altitude;
  for (const Vec3& p : points) {
    planar.push_back(p.head<2>());
    altitude.push_back(p.z());
  }
  World world = testing::fully_linked_world(std::move(planar), anchors, std::move(altitude));
  world.comm_radius_m = 100.0;
  return world;
}

/// Anchors 0–4 at several heights around a 20 m box, unknowns 5–7 inside it.
World box_world() {
  return spatial_world({{0.0, 0.0, 0.0},
                        {20.0, 0.0, 6.0},
                        {20.0, 20.0, 1.0},
                        {0.0, 20.0, 9.0},
                        {10.0, 10.0, 12.0},
                        {6.0, 7.0, 3.0},
                        {13.0, 5.0, 8.0},
                        {9.0, 15.0, 2.0}},
                       5);
}

config::Scenario spatial_scenario(double range_std_m, int steps) {
  config::Scenario s;
  s.seed = 31;
  s.algorithm.name = "dml";
  s.world.agents = 8;
  s.world.anchors = 5;
  s.world.comm_radius_m = 100.0;
  s.noise.range_std_m = range_std_m;
  s.run.steps = steps;
  return s;
}

/// One step's batches: every agent's draw of the range to each neighbour (per endpoint, σ from the
/// scenario's noise model at the 3-D distance).
std::vector<estimators::MeasurementBatch> draw_batches(const World& world, const config::Scenario& s,
                                                       std::int64_t step, std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  std::vector<estimators::MeasurementBatch> batches(static_cast<std::size_t>(world.size()));
  for (AgentId i = 0; i < world.size(); ++i) {
    auto& batch = batches[static_cast<std::size_t>(i)];
    batch.world_step = step;
    for (const AgentId j : world.neighbours[static_cast<std::size_t>(i)]) {
      const double distance = world.distance(i, j);
      const double std_m = s.noise.range_std_at(distance);
      batch.ranges.push_back({j, distance + std_m * normal(rng), std_m});
    }
  }
  return batches;
}

/// One raw draw: ‖x_a − x_b‖ = range, b < 0: x_b is the known point.
struct RawRange3 {
  int a = 0;
  int b = -1;
  Vec3 known = Vec3::Zero();
  double range = 0.0;
  double variance = 1.0;
};

std::vector<RawRange3> raw_ranges3(const World& world,
                                   const std::vector<std::vector<estimators::MeasurementBatch>>& steps) {
  std::vector<int> variable(static_cast<std::size_t>(world.size()), -1);
  int next = 0;
  for (std::size_t i = 0; i < variable.size(); ++i)
    if (!world.is_anchor[i]) variable[i] = next++;
  std::vector<RawRange3> terms;
  for (const auto& batches : steps) {
    for (AgentId i = 0; i < world.size(); ++i) {
      for (const auto& r : batches[static_cast<std::size_t>(i)].ranges) {
        int a = variable[static_cast<std::size_t>(i)];
        int b = variable[static_cast<std::size_t>(r.peer)];
        AgentId known = r.peer;
        if (a < 0) std::swap(a, b), known = i;
        if (a < 0) continue;
        terms.push_back({a, b, world.position3(known), r.range_m, r.std_m * r.std_m});
      }
    }
  }
  return terms;
}

Vec3 raw_other(const RawRange3& t, const VecX& x) { return t.b < 0 ? t.known : Vec3(x.segment<3>(3 * t.b)); }

double raw_cost3(const std::vector<RawRange3>& terms, const VecX& x) {
  double cost = 0.0;
  for (const auto& t : terms) {
    const double e = t.range - (x.segment<3>(3 * t.a) - raw_other(t, x)).norm();
    cost += e * e / t.variance;
  }
  return cost;
}

/// JᵀR⁻¹J of the raw draws at x, and JᵀR⁻¹e in `gradient`.
MatX raw_information3(const std::vector<RawRange3>& terms, const VecX& x, VecX* gradient = nullptr) {
  MatX H = MatX::Zero(x.size(), x.size());
  if (gradient != nullptr) *gradient = VecX::Zero(x.size());
  for (const auto& t : terms) {
    const Vec3 d = x.segment<3>(3 * t.a) - raw_other(t, x);
    VecX row = VecX::Zero(x.size());
    row.segment<3>(3 * t.a) = d / d.norm();
    if (t.b >= 0) row.segment<3>(3 * t.b) = -d / d.norm();
    H += row * row.transpose() / t.variance;
    if (gradient != nullptr) *gradient += row * (t.range - d.norm()) / t.variance;
  }
  return H;
}

/// Dense Gauss–Newton with step halving from x: a local minimum.
VecX dense_minimum3(const std::vector<RawRange3>& terms, VecX x) {
  for (int iteration = 0; iteration < 200; ++iteration) {
    VecX g;
    const MatX H = raw_information3(terms, x, &g);
    const VecX dx = H.ldlt().solve(g);
    const double cost = raw_cost3(terms, x);
    double scale = 1.0;
    VecX trial = x;
    for (int halving = 0; halving < 40; ++halving, scale /= 2.0) {
      trial = x + scale * dx;
      if (raw_cost3(terms, trial) <= cost) break;
    }
    x = trial;
    if (!(scale * dx.cwiseAbs().maxCoeff() >= 1e-13)) break;
  }
  return x;
}

OptimumEstimate spatial_optimum(const World& world, const config::Scenario& s,
                                const std::vector<std::vector<estimators::MeasurementBatch>>& steps) {
  OptimumAccumulator accumulator(world, s);
  for (std::size_t k = 0; k < steps.size(); ++k)
    accumulator.observe(static_cast<std::int64_t>(k), world.truth, steps[k]);
  return accumulator.solve_now();
}

// ---- The bound ----

TEST(Bound3, TheStaticBoundOfA3dWorldIsTheCrlbOfItsRangesInSpace) {
  // Proportional noise (σ = 1 % of the 3-D distance), every edge drawn at both ends: J built entry by entry.
  const World world = box_world();
  auto s = spatial_scenario(0.0, 4);
  s.noise.range_model = config::RangeNoise::kProportional;
  s.noise.range_factor = 0.01;
  MatX J = MatX::Zero(9, 9);
  for (AgentId i = 5; i < 8; ++i) {
    for (AgentId j = 0; j < 8; ++j) {
      if (j == i) continue;
      const Vec3 d = world.position3(i) - world.position3(j);
      const double sigma = 0.01 * d.norm();
      const Mat3 block = 2.0 * d * d.transpose() / d.squaredNorm() / (sigma * sigma);  // two draws
      const int a = 3 * (i - 5);
      J.block<3, 3>(a, a) += block;
      if (j >= 5) J.block<3, 3>(a, 3 * (j - 5)) -= block;
    }
  }
  const double expected = std::sqrt(J.inverse().trace() / 3.0);
  const RangeCrlb legacy = scenario_crlb(world, s);
  EXPECT_NEAR(legacy.single_snapshot_rmse_m, expected, 1e-12 * expected);
  const RunBound bound = run_bound(world, s, legacy);
  ASSERT_EQ(bound.kind, BoundKind::kCrlbStaticAccumulated) << bound.reason;
  EXPECT_NEAR(bound.single_rmse_m, expected, 1e-12 * expected);
  EXPECT_NEAR(bound.rmse_at(3), expected / 2.0, 1e-12 * expected);  // four steps of fresh draws
  RecordProperty("single_snapshot_bound_m", std::to_string(expected));
}

// Moving truth in space: the world's random walk moves x, y and z of every non-anchor, and the PCRB is the
// information recursion J_k = (J_{k-1}^{-1} + q I)^{-1} + H_k^T R^{-1} H_k along that trajectory, built here
// block by block in space from the prior of the initial guesses.
TEST(Bound3, TheBoundOfMovingTruthInSpaceIsThePosteriorCrbOfItsWalk) {
  const World world = box_world();
  auto s = spatial_scenario(0.3, 6);
  s.world.motion = config::Motion::kRandomWalk;
  s.world.motion_std_m = 0.4;
  s.world.initial_guess_std_m = 1.5;
  const double q = s.world.motion_std_m * s.world.motion_std_m;
  const double sigma = s.noise.range_std_m;
  MatX J = MatX::Identity(9, 9) / (s.world.initial_guess_std_m * s.world.initial_guess_std_m);
  World walked = world;
  std::vector<double> expected;
  for (std::int64_t step = 0; step < s.run.steps; ++step) {
    if (step > 0) {
      const std::vector<double> z_before = walked.altitude;
      advance_truth(walked, s, step);
      for (AgentId i = 0; i < walked.size(); ++i) {
        const double dz =
            walked.altitude[static_cast<std::size_t>(i)] - z_before[static_cast<std::size_t>(i)];
        if (walked.is_anchor[static_cast<std::size_t>(i)]) {
          EXPECT_EQ(dz, 0.0) << "anchor " << i << " step " << step;
        } else {
          EXPECT_NE(dz, 0.0) << "agent " << i << " step " << step;
        }
      }
      J = (J.inverse() + q * MatX::Identity(9, 9)).inverse();
    }
    for (AgentId i = 5; i < 8; ++i) {
      for (AgentId j = 0; j < 8; ++j) {
        if (j == i) continue;
        const Vec3 d = walked.position3(i) - walked.position3(j);
        const Mat3 block = 2.0 * d * d.transpose() / d.squaredNorm() / (sigma * sigma);  // two draws
        const int a = 3 * (i - 5);
        J.block<3, 3>(a, a) += block;
        if (j >= 5) J.block<3, 3>(a, 3 * (j - 5)) -= block;
      }
    }
    expected.push_back(std::sqrt(J.inverse().trace() / 3.0));
  }
  const RunBound bound = run_bound(world, s, scenario_crlb(world, s));
  ASSERT_EQ(bound.kind, BoundKind::kPcrb) << bound.reason;
  ASSERT_EQ(bound.pcrb_rmse_m.size(), expected.size());
  for (std::size_t k = 0; k < expected.size(); ++k)
    EXPECT_NEAR(bound.pcrb_rmse_m[k], expected[k], 1e-9 * expected[k]) << "step " << k;
}

// ---- The batch ML ----

TEST(Optimum3, EqualsTheBestOfManyRestartsAndItsCovarianceIsTheInverseFisher) {
  const World world = box_world();
  const auto s = spatial_scenario(0.4, 3);
  std::mt19937_64 rng(101);
  std::vector<std::vector<estimators::MeasurementBatch>> steps;
  for (std::int64_t k = 0; k < s.run.steps; ++k) steps.push_back(draw_batches(world, s, k, rng));
  const OptimumEstimate optimum = spatial_optimum(world, s, steps);
  ASSERT_TRUE(optimum.solved);
  ASSERT_EQ(optimum.altitude.size(), 8U);
  ASSERT_EQ(optimum.truth_z.size(), 8U);

  const auto terms = raw_ranges3(world, steps);
  std::uniform_real_distribution<double> coordinate(-5.0, 25.0);
  VecX best;
  double best_cost = std::numeric_limits<double>::infinity();
  for (int restart = 0; restart < 300; ++restart) {
    VecX start(9);
    for (Eigen::Index k = 0; k < 9; ++k) start(k) = coordinate(rng);
    const VecX x = dense_minimum3(terms, start);
    if (const double cost = raw_cost3(terms, x); cost < best_cost) best_cost = cost, best = x;
  }
  const MatX covariance = raw_information3(terms, best).inverse();
  for (std::size_t i = 5; i < 8; ++i) {
    const auto v = static_cast<Eigen::Index>(3 * (i - 5));
    const Vec3 x = join(optimum.position[i], optimum.altitude[i].z_m);
    EXPECT_LT((x - best.segment<3>(v)).norm(), 1e-6) << "agent " << i;
    EXPECT_GT((x - world.position3(static_cast<AgentId>(i))).norm(), 1e-3) << "the ML is not the truth";
    const Mat3 expected = covariance.block<3, 3>(v, v);
    const Mat3 solved = join(optimum.covariance[i], optimum.altitude[i]);
    EXPECT_LT((solved - expected).norm(), 1e-8 * expected.norm()) << "agent " << i;
    EXPECT_EQ(optimum.truth_z[i], world.altitude[i]);
  }
  // A known anchor keeps its position with its z.
  EXPECT_FALSE(optimum.in_state[4]);
  EXPECT_EQ(optimum.altitude[4].z_m, 12.0);
}

TEST(Optimum3, OverManyDrawsItsRmseIsTheCrlbAndItsNeesThree) {
  // 500 independent one-step draws of the fixed box world (σ = 0.1 m, both ends): the ML's mean squared
  // error over draws and agents against tr(CRB)/n_u, and its NEES against 3 degrees of freedom.
  constexpr int kDraws = 500;
  const World world = box_world();
  const auto s = spatial_scenario(0.1, 1);
  const RangeCrlb crlb = scenario_crlb(world, s);
  std::mt19937_64 rng(7);
  double mse = 0.0;
  double nees = 0.0;
  for (int draw = 0; draw < kDraws; ++draw) {
    const OptimumEstimate optimum = spatial_optimum(world, s, {draw_batches(world, s, 0, rng)});
    ASSERT_TRUE(optimum.solved);
    mse += optimum.point.rmse_m * optimum.point.rmse_m / kDraws;
    nees += optimum.point.nees / kDraws;
  }
  const double ratio = std::sqrt(mse) / crlb.single_snapshot_rmse_m;
  EXPECT_NEAR(ratio, 1.0, 0.1);
  EXPECT_NEAR(nees, 3.0, 0.3);
  RecordProperty("optimum_over_crlb", std::to_string(ratio));
  RecordProperty("mean_nees", std::to_string(nees));
  std::printf("3-D optimum over %d draws: RMSE / CRLB %.4f (CRLB %.5f m), mean NEES %.4f\n", kDraws, ratio,
              crlb.single_snapshot_rmse_m, nees);
}

TEST(Optimum3, AMirrorImageIsTheOptimumWhereAnEstimateWithItsZFoundIt) {
  // Anchors 0–2 at z = 0 and agent 3 at z = 3 ranging to them: its mirror at z = −3 fits the same ranges.
  World world = spatial_world({{0.0, 0.0, 0.0}, {10.0, 0.0, 0.0}, {0.0, 10.0, 0.0}, {4.0, 3.0, 3.0}}, 3);
  const auto s = spatial_scenario(0.05, 5);
  std::mt19937_64 rng(5);
  std::vector<std::vector<estimators::MeasurementBatch>> steps;
  for (std::int64_t k = 0; k < s.run.steps; ++k) steps.push_back(draw_batches(world, s, k, rng));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Vec2> planar = {{nan, nan}, {nan, nan}, {nan, nan}, {4.05, 2.95}};
  auto final_optimum = [&](const std::vector<double>* z) {
    OptimumAccumulator accumulator(world, s);
    for (std::size_t k = 0; k < steps.size(); ++k)
      accumulator.observe(static_cast<std::int64_t>(k), world.truth, steps[k]);
    accumulator.solve_pending(true, &planar, z);
    return accumulator.result();
  };
  const std::vector<double> mirror_z = {nan, nan, nan, -2.9};
  const RunOptimum mirror = final_optimum(&mirror_z);
  ASSERT_FALSE(mirror.points.empty());
  EXPECT_TRUE(mirror.points.back().from_estimates);
  EXPECT_NEAR(mirror.points.back().rmse_m, 6.0, 0.1)
      << "the optimum in the mirror basin, 6 m below the truth";
  ASSERT_EQ(mirror.final_altitude.size(), 4U);
  EXPECT_NEAR(mirror.final_altitude[3].z_m, -3.0, 0.1);
  EXPECT_EQ(mirror.final_truth_z[3], 3.0);

  // Without its z the estimate is no 3-D start: the truth's solution.
  const RunOptimum no_z = final_optimum(nullptr);
  EXPECT_FALSE(no_z.points.back().from_estimates);
  EXPECT_LT(no_z.points.back().rmse_m, 0.1);
  EXPECT_NEAR(no_z.final_altitude[3].z_m, 3.0, 0.1);
}

// ---- Anchor fixes in space and moving truth ----

/// One raw term of a MAP in space over blocks of 3: a point x_a ~ N(value, v I), a step x_b − x_a ~ N(0, v
/// I), or a range ‖x_a − x_b‖ (b < 0: to `value`).
struct RawTerm3 {
  enum Kind { kPoint, kStep, kRange } kind = kPoint;
  int a = 0;
  int b = -1;
  Vec3 value = Vec3::Zero();
  double range = 0.0;
  double variance = 1.0;
};

/// The whitened residuals of `terms` at x and their Jacobian.
void raw_residuals3(const std::vector<RawTerm3>& terms, const VecX& x, VecX& r, MatX& J) {
  Eigen::Index rows = 0;
  for (const auto& t : terms) rows += t.kind == RawTerm3::kRange ? 1 : 3;
  r = VecX::Zero(rows);
  J = MatX::Zero(rows, x.size());
  Eigen::Index row = 0;
  for (const auto& t : terms) {
    const double w = 1.0 / std::sqrt(t.variance);
    const Vec3 xa = x.segment<3>(3 * t.a);
    if (t.kind == RawTerm3::kPoint) {
      r.segment<3>(row) = w * (xa - t.value);
      J.block<3, 3>(row, 3 * t.a) = w * Mat3::Identity();
    } else if (t.kind == RawTerm3::kStep) {
      r.segment<3>(row) = w * (x.segment<3>(3 * t.b) - xa);
      J.block<3, 3>(row, 3 * t.a) = -w * Mat3::Identity();
      J.block<3, 3>(row, 3 * t.b) = w * Mat3::Identity();
    } else {
      const Vec3 d = xa - (t.b < 0 ? t.value : Vec3(x.segment<3>(3 * t.b)));
      r(row) = w * (d.norm() - t.range);
      J.block<1, 3>(row, 3 * t.a) = w * d.transpose() / d.norm();
      if (t.b >= 0) J.block<1, 3>(row, 3 * t.b) = -w * d.transpose() / d.norm();
    }
    row += t.kind == RawTerm3::kRange ? 1 : 3;
  }
}

/// Dense Gauss–Newton from x (started at the truth: one basin); its inverse information in `covariance`.
VecX dense_map3(const std::vector<RawTerm3>& terms, VecX x, MatX& covariance) {
  VecX r;
  MatX J;
  for (int iteration = 0; iteration < 100; ++iteration) {
    raw_residuals3(terms, x, r, J);
    const VecX dx = (J.transpose() * J).ldlt().solve(-J.transpose() * r);
    x += dx;
    if (dx.cwiseAbs().maxCoeff() < 1e-13) break;
  }
  raw_residuals3(terms, x, r, J);
  covariance = (J.transpose() * J).inverse();
  return x;
}

// The anchors are unknowns with noisy fixes whose z travels with them (AbsoluteFix::z_m), and the agents walk
// in space: the optimum is the MAP of the whole trajectory (priors on the initial guesses, the world's walk
// in x, y and z, every range and fix), built here densely from the raw draws; without the walk it is the
// batch ML of every draw and fix.
TEST(Optimum3, WithFixesAndWalkingTruthItIsTheDenseMapOfTheRawData) {
  for (const bool moving : {false, true}) {
    SCOPED_TRACE(moving ? "walking truth" : "static truth");
    World world = box_world();
    auto s = spatial_scenario(0.3, 6);
    s.noise.anchor_fix_std_m = 0.7;  // dml's data: every draw, the anchors in the state with their fixes
    s.world.initial_guess_std_m = 1.5;
    if (moving) {
      s.world.motion = config::Motion::kRandomWalk;
      s.world.motion_std_m = 0.3;
    }
    std::mt19937_64 rng(17);
    std::normal_distribution<double> gauss;
    for (std::size_t i = 0; i < world.truth.size(); ++i) {
      world.initial_guess[i] = world.truth[i] + 1.5 * Vec2(gauss(rng), gauss(rng));
      world.initial_altitude[i] = world.altitude[i] + 1.5 * gauss(rng);
    }
    const World start = world;
    OptimumAccumulator accumulator(start, s);
    const int steps = static_cast<int>(s.run.steps);
    // Blocks: agents 5–7 at each step (once if static), then anchors 0–4.
    const int moving_blocks = moving ? 3 * steps : 3;
    auto block = [&](int agent, int step) {
      return agent < 5 ? moving_blocks + agent : (moving ? 3 * step : 0) + agent - 5;
    };
    std::vector<RawTerm3> terms;
    VecX x0 = VecX::Zero(3 * (moving_blocks + 5));
    for (int k = 0; k < steps; ++k) {
      if (k > 0) advance_truth(world, s, k);
      auto batches = draw_batches(world, s, k, rng);
      for (AgentId i = 0; i < 8; ++i) {
        x0.segment<3>(3 * block(i, k)) = world.position3(i);
        if (i < 5) {
          const Vec3 fix = world.position3(i) + 0.7 * Vec3(gauss(rng), gauss(rng), gauss(rng));
          batches[static_cast<std::size_t>(i)].fix =
              estimators::AbsoluteFix{fix.head<2>(), 0.49 * Mat2::Identity(), fix.z()};
          terms.push_back({RawTerm3::kPoint, block(i, k), -1, fix, 0.0, 0.49});
        } else if (k > 0 && moving) {
          terms.push_back({RawTerm3::kStep, block(i, k - 1), block(i, k), Vec3::Zero(), 0.0, 0.09});
        }
        for (const auto& r : batches[static_cast<std::size_t>(i)].ranges)
          terms.push_back(
              {RawTerm3::kRange, block(i, k), block(r.peer, k), Vec3::Zero(), r.range_m, r.std_m * r.std_m});
      }
      accumulator.observe(k, world.truth, batches, world.altitude);
    }
    for (AgentId i = 0; i < 8 && moving; ++i) {
      const auto at = static_cast<std::size_t>(i);
      terms.push_back({RawTerm3::kPoint, block(i, 0), -1,
                       join(start.initial_guess[at], start.initial_altitude[at]), 0.0, 2.25});
    }
    MatX covariance;
    const VecX reference = dense_map3(terms, x0, covariance);
    const OptimumEstimate optimum = accumulator.solve_now();
    ASSERT_TRUE(optimum.solved);
    ASSERT_EQ(optimum.altitude.size(), 8U);
    for (AgentId i = 0; i < 8; ++i) {
      const auto at = static_cast<std::size_t>(i);
      const int b = block(i, steps - 1);
      const Vec3 solved = join(optimum.position[at], optimum.altitude[at].z_m);
      EXPECT_LT((solved - reference.segment<3>(3 * b)).norm(), 1e-8) << "agent " << i;
      EXPECT_GT((solved - world.position3(i)).norm(), 1e-3) << "agent " << i << ": the MAP is not the truth";
      const Mat3 expected = covariance.block<3, 3>(3 * b, 3 * b);
      EXPECT_LT((join(optimum.covariance[at], optimum.altitude[at]) - expected).norm(),
                1e-8 * expected.norm())
          << "agent " << i;
      EXPECT_EQ(optimum.truth_z[at], world.altitude[at]) << "agent " << i;
    }
  }
}

}  // namespace
}  // namespace swarmloc::world
