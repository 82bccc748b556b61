// The run's bound (docs/algorithms.md §1.3.1): the data table, the static accumulated CRLB of each data
// selection against a hand-built Fisher matrix and against a batch maximum-likelihood solve on the world's
// own draws, the posterior CRB against a Kalman covariance recursion, and the bound the shipped scenarios
// report (what a simulated run's summary reports of it: tests/unit/sim/test_simulated_bound.cpp).
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <string>
#include <vector>

#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/run/fusion_centre.hpp"
#include "swarmloc/world/bound.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::world {
namespace {

const std::string kBoundScenarios = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/";

/// Anchors 0–3 at the corners of a 10 m square, unknowns 4–6 inside; every pair in range.
World small_bound_world() {
  World world;
  world.truth = {{0.0, 0.0}, {10.0, 0.0}, {10.0, 10.0}, {0.0, 10.0}, {3.0, 4.0}, {7.0, 3.0}, {5.0, 7.5}};
  world.is_anchor = {true, true, true, true, false, false, false};
  world.neighbours.resize(world.truth.size());
  for (std::size_t i = 0; i < world.truth.size(); ++i) {
    for (std::size_t j = 0; j < world.truth.size(); ++j) {
      if (i != j) world.neighbours[i].push_back(static_cast<AgentId>(j));
    }
  }
  world.initial_guess = world.truth;
  return world;
}

config::Scenario small_bound_scenario(const std::string& algorithm) {
  config::Scenario s;
  s.seed = 11;
  s.algorithm.name = algorithm;
  s.world.agents = 7;
  s.world.anchors = 4;
  s.world.comm_radius_m = 100.0;
  s.noise.range_std_m = 0.1;
  s.run.steps = 5;
  return s;
}

// ---- The table ----

TEST(BoundData, EveryAlgorithmHasARowAndTheDeclaredDataMatchesItsCode) {
  for (const std::string name :
       {"ieif", "iekf", "ekf", "lbekf", "lbekf_vr", "lbekf_i", "jacobi", "dle", "joint_field", "multipath_bp",
        "dgbb", "local_bb", "fixed_step", "step_length", "pose_ekf", "pose_ieif", "dead_reckoning", "dml"}) {
    EXPECT_EQ(bound_data(name).algorithm, name) << name << " has no row";
  }
  for (const auto& name : config::agent_algorithms()) EXPECT_EQ(bound_data(name).algorithm, name);
  EXPECT_EQ(bound_data("ieif").draws, RangeDraws::kOwnDraws);
  EXPECT_EQ(bound_data("ekf").draws, RangeDraws::kOnePerEdge);
  EXPECT_EQ(bound_data("ekf").anchors, AnchorData::kFixes);
  EXPECT_EQ(bound_data("dml").draws, RangeDraws::kAllDraws);
  EXPECT_EQ(bound_data("no_such_algorithm").model, BoundModel::kNone);
}

// ---- (c) the data-specific bounds equal a hand-built Fisher matrix and are ordered ----

/// sqrt(tr(J⁻¹)/3) for the small world's three unknowns, with `anchor_draws`/`pair_draws` range draws on
/// each anchor–unknown / unknown–unknown edge (σ = 0.1 m), built entry by entry.
double hand_built_bound(int anchor_draws, int pair_draws) {
  const World world = small_bound_world();
  MatX J = MatX::Zero(6, 6);
  for (int i = 4; i < 7; ++i) {
    for (int j = 0; j < 7; ++j) {
      if (j == i) continue;
      const Vec2 d = world.truth[static_cast<std::size_t>(i)] - world.truth[static_cast<std::size_t>(j)];
      const Vec2 u = d / d.norm();
      const Mat2 block = u * u.transpose() / 0.01;
      const int a = 2 * (i - 4);
      if (j < 4) {
        J.block<2, 2>(a, a) += anchor_draws * block;
      } else if (j > i) {
        const int b = 2 * (j - 4);
        J.block<2, 2>(a, a) += pair_draws * block;
        J.block<2, 2>(b, b) += pair_draws * block;
        J.block<2, 2>(a, b) -= pair_draws * block;
        J.block<2, 2>(b, a) -= pair_draws * block;
      }
    }
  }
  return std::sqrt(J.inverse().trace() / 3.0);
}

double static_bound_of(const std::string& algorithm, bool shared_draws = false) {
  auto s = small_bound_scenario(algorithm);
  s.noise.shared_range_draws = shared_draws;
  const World world = small_bound_world();
  return run_bound(world, s, scenario_crlb(world, s)).single_rmse_m;
}

TEST(StaticBound, EachDataSelectionEqualsItsHandBuiltFisherMatrix) {
  // ieif: an unknown's own draw of each anchor edge, both unknowns' draws of a pair edge.
  EXPECT_NEAR(static_bound_of("ieif"), hand_built_bound(1, 2), 1e-12);
  // ekf: one draw per edge (anchor_fix_std_m = 0: its anchors are known).
  EXPECT_NEAR(static_bound_of("ekf"), hand_built_bound(1, 1), 1e-12);
  EXPECT_NEAR(static_bound_of("dml"), hand_built_bound(2, 2), 1e-12);
  // Shared draws: both ends hold one value, every selection has one draw per edge.
  for (const std::string name : {"ieif", "ekf", "dml"})
    EXPECT_NEAR(static_bound_of(name, true), hand_built_bound(1, 1), 1e-12) << name;
}

TEST(StaticBound, LessDataNeverBoundsLower) {
  // Each selection's draws contain the next one's: one per edge ⊂ own draws ⊂ all draws.
  const double one_per_edge = static_bound_of("ekf");
  const double own_draws = static_bound_of("ieif");
  const double all_draws = static_bound_of("dml");
  EXPECT_GT(one_per_edge, own_draws);
  EXPECT_GT(own_draws, all_draws);
  const auto s = small_bound_scenario("ieif");
  const World world = small_bound_world();
  const RunBound bound = run_bound(world, s, scenario_crlb(world, s));
  EXPECT_EQ(bound.kind, BoundKind::kCrlbStaticAccumulated);
  EXPECT_NEAR(bound.all_data_single_rmse_m, all_draws, 1e-12);
  EXPECT_NEAR(bound.rmse_at(3), own_draws / 2.0, 1e-12) << "accumulated over 4 snapshots";
}

TEST(StaticBound, AnchorFixesPutTheAnchorsInTheState) {
  auto s = small_bound_scenario("ekf");
  s.noise.anchor_fix_std_m = 0.5;
  const World world = small_bound_world();
  const auto network = snapshot_network(world, s, world.truth, RangeDraws::kOnePerEdge, AnchorData::kFixes);
  EXPECT_EQ(network.absolute.size(), 4U);
  EXPECT_EQ(std::count(network.is_anchor.begin(), network.is_anchor.end(), true), 0);
  EXPECT_GT(static_bound_of("ekf"), 0.0);
  EXPECT_GT(run_bound(world, s, scenario_crlb(world, s)).single_rmse_m, static_bound_of("ekf"))
      << "noisy anchors: a weaker bound than known ones";
}

// ---- (b) a batch ML on the world's draws reaches the data-specific accumulated CRLB ----

/// One directed range the ML uses: agent `from` measured `to`.
struct MlRange {
  int from = 0;
  int to = 0;
  double range_m = 0.0;
};

/// The ranges each algorithm receives, from the world's own batches: ieif the non-anchors' batches, ekf
/// what the fusion centre takes (run::centralized_measurements), dml every batch.
std::vector<MlRange> ml_ranges(const World& world, const config::Scenario& s, std::int64_t steps) {
  std::vector<MlRange> out;
  for (std::int64_t step = 0; step < steps; ++step) {
    std::vector<estimators::MeasurementBatch> batches;
    for (AgentId i = 0; i < world.size(); ++i) batches.push_back(generate_batch(world, s, i, step));
    if (s.algorithm.name == "ekf") {
      std::vector<const estimators::MeasurementBatch*> pointers;
      for (const auto& b : batches) pointers.push_back(&b);
      for (const auto& r : run::centralized_measurements(s, pointers).ranges)
        out.push_back({r.i, r.j, r.range_m});
      continue;
    }
    for (AgentId i = 0; i < world.size(); ++i) {
      if (s.algorithm.name == "ieif" && world.is_anchor[static_cast<std::size_t>(i)]) continue;
      for (const auto& r : batches[static_cast<std::size_t>(i)].ranges) out.push_back({i, r.peer, r.range_m});
    }
  }
  return out;
}

/// Gauss–Newton on the unknowns (agents 4–6), anchors known, from the truth; the squared error at the end.
double ml_squared_error(const World& world, const std::vector<MlRange>& ranges) {
  std::vector<Vec2> x = world.truth;
  for (int iteration = 0; iteration < 20; ++iteration) {
    MatX normal = MatX::Zero(6, 6);
    VecX gradient = VecX::Zero(6);
    for (const auto& r : ranges) {
      const Vec2 d = x[static_cast<std::size_t>(r.from)] - x[static_cast<std::size_t>(r.to)];
      const Vec2 u = d / d.norm();
      const double residual = r.range_m - d.norm();
      for (const auto& [agent, sign] : {std::pair{r.from, 1.0}, std::pair{r.to, -1.0}}) {
        if (agent < 4) continue;
        gradient.segment<2>(2 * (agent - 4)) += sign * u * residual;
        for (const auto& [other, other_sign] : {std::pair{r.from, 1.0}, std::pair{r.to, -1.0}}) {
          if (other >= 4)
            normal.block<2, 2>(2 * (agent - 4), 2 * (other - 4)) += sign * other_sign * u * u.transpose();
        }
      }
    }
    const VecX step = normal.ldlt().solve(gradient);
    for (int a = 0; a < 3; ++a) x[static_cast<std::size_t>(4 + a)] += step.segment<2>(2 * a);
    if (step.norm() < 1e-12) break;
  }
  double squared = 0.0;
  for (std::size_t i = 4; i < 7; ++i) squared += (x[i] - world.truth[i]).squaredNorm();
  return squared;
}

TEST(StaticBound, BatchMaximumLikelihoodOnTheAlgorithmsDataReachesItsBound) {
  constexpr int kTrials = 600;
  for (const std::string name : {"ieif", "ekf", "dml"}) {
    const auto s = small_bound_scenario(name);
    World world = small_bound_world();
    const RunBound bound = run_bound(world, s, scenario_crlb(world, s));
    double mse = 0.0;
    for (int trial = 0; trial < kTrials; ++trial) {
      world.trial = static_cast<std::uint64_t>(trial);
      mse += ml_squared_error(world, ml_ranges(world, s, s.run.steps)) / 3.0 / kTrials;
    }
    const double ratio = std::sqrt(mse) / bound.rmse_at(s.run.steps - 1);
    EXPECT_NEAR(ratio, 1.0, 0.05) << name << ": ML RMSE " << std::sqrt(mse) << " m";
    RecordProperty(name + "_ml_over_bound", std::to_string(ratio));
  }
}

// ---- (a) the posterior CRB equals a Kalman filter's covariance with H at the true trajectory ----

/// Covariance-form Kalman filter over all seven agents, one scalar update at a time with H at the truth:
/// the same information as the PCRB, reached by a different recursion. Known anchors start with P = 0;
/// anchors with fixes start from the world's initial-guess spread and take a fix per step. Returns
/// sqrt(tr(P_k)/3) over the unknowns per step.
std::vector<double> kalman_covariance_rmse(const World& start, const config::Scenario& s, bool ieif_draws) {
  World world = start;
  const bool anchor_fixes = !ieif_draws && s.noise.anchor_fix_std_m > 0.0;
  MatX P = MatX::Identity(14, 14) * s.world.initial_guess_std_m * s.world.initial_guess_std_m;
  if (!anchor_fixes) P.topLeftCorner(8, 8).setZero();
  auto update = [&P](const VecX& h, double variance) {
    const VecX Ph = P * h;
    P -= Ph * Ph.transpose() / (h.dot(Ph) + variance);
  };
  std::vector<double> out;
  for (std::int64_t step = 0; step < s.run.steps; ++step) {
    if (step > 0) {
      advance_truth(world, s, step);
      // The world's random walk moves the unknowns only.
      P.diagonal().tail(6).array() += s.world.motion_std_m * s.world.motion_std_m;
    }
    for (int i = 0; i < 7; ++i) {
      for (int j = i + 1; j < 7; ++j) {
        const Vec2 d = world.truth[static_cast<std::size_t>(i)] - world.truth[static_cast<std::size_t>(j)];
        if (d.norm() > s.world.comm_radius_m) continue;  // out of range this step
        VecX h = VecX::Zero(14);
        h.segment<2>(2 * i) = d / d.norm();
        h.segment<2>(2 * j) = -d / d.norm();
        const int draws = (i < 4 && ieif_draws) ? 1 : 2;  // ieif: the anchors' own draws are unused
        for (int k = 0; k < draws; ++k) update(h, s.noise.range_std_m * s.noise.range_std_m);
      }
    }
    for (int a = 0; anchor_fixes && a < 8; ++a)
      update(VecX::Unit(14, a), s.noise.anchor_fix_std_m * s.noise.anchor_fix_std_m);
    out.push_back(std::sqrt(P.bottomRightCorner(6, 6).trace() / 3.0));
  }
  return out;
}

TEST(PosteriorBound, EqualsTheKalmanCovarianceAlongTheTrueTrajectoryWithTheWorldsProcessNoise) {
  for (const std::string name : {"ieif", "dml"}) {
    auto s = small_bound_scenario(name);
    s.world.motion = config::Motion::kRandomWalk;
    s.world.motion_std_m = 0.3;
    s.algorithm.kalman.process_noise_std_m = 0.01;  // the filter's Q: not the bound's
    s.world.initial_guess_std_m = 1.5;
    s.world.comm_radius_m = 9.0;  // edges leave and enter the range as the agents move
    s.noise.range_std_m = 0.5;
    s.noise.anchor_fix_std_m = 0.7;  // dml's anchors are in the state; ieif's are known
    s.run.steps = 30;
    const World world = small_bound_world();
    const RunBound bound = run_bound(world, s, scenario_crlb(world, s));
    ASSERT_EQ(bound.kind, BoundKind::kPcrb) << bound.reason;
    const auto kalman = kalman_covariance_rmse(world, s, name == "ieif");
    for (std::int64_t k = 0; k < s.run.steps; ++k)
      EXPECT_NEAR(bound.rmse_at(k), kalman[static_cast<std::size_t>(k)], 1e-9) << name << " step " << k;
    EXPECT_GT(bound.rmse_at(s.run.steps - 1), bound.all_data_rmse_at(s.run.steps - 1) - 1e-12);
  }
}

TEST(PosteriorBound, PredictionAddsTheProcessVarianceToTheCovariance) {
  MatX J(2, 2);
  J << 4.0, 1.0, 1.0, 3.0;
  const MatX predicted = pcrb_predict(J, VecX::Constant(2, 0.25));
  const MatX expected = (J.inverse() + 0.25 * MatX::Identity(2, 2)).inverse();
  EXPECT_LT((predicted - expected).norm(), 1e-12);
}

TEST(PosteriorBound, AMovingTargetsBoundEqualsTheKalmanCovarianceOfItsLinearReadings) {
  auto s = config::load_scenario(kBoundScenarios + "dle_tracking.yaml", {"run.steps=40"});
  s.world.target_sensing = config::TargetSensing::kLinear;
  s.world.target_sensing_radius_m = 15.0;  // the moving target leaves and enters sensors' ranges
  World world = build_world(s);
  const RunBound bound = run_bound(world, s, scenario_crlb(world, s));
  ASSERT_EQ(bound.kind, BoundKind::kPcrb) << bound.reason;
  const config::TargetModel model = config::target_model(s);
  MatX P = MatX::Identity(4, 4) * 1e6;  // the bound's diffuse start
  const double variance = s.noise.target_std_m * s.noise.target_std_m;
  for (std::int64_t step = 0; step < s.run.steps; ++step) {
    if (step > 0) {
      advance_truth(world, s, step);
      P = model.F * P * model.F.transpose() + model.W;
    }
    for (const Vec2& sensor : world.truth) {
      if ((sensor - world.target.head<2>()).norm() > s.world.target_sensing_radius_m) continue;
      const MatX gain = P.leftCols<2>() * (P.topLeftCorner<2, 2>() + variance * Mat2::Identity()).inverse();
      P -= gain * P.topRows<2>();
    }
    EXPECT_NEAR(bound.rmse_at(step), std::sqrt(P.topLeftCorner<2, 2>().trace()), 1e-6 * bound.rmse_at(step))
        << "step " << step;
  }
}

// ---- The shipped scenarios ----

TEST(RunBoundReport, TheDefaultWorldReportsTheStaticBoundOfIeifsOwnDraws) {
  auto s = config::load_scenario(kBoundScenarios + "ieif.yaml", {"run.steps=20"});
  const World world = build_world(s);
  const RangeCrlb legacy = scenario_crlb(world, s);
  const RunBound bound = run_bound(world, s, legacy);
  EXPECT_EQ(bound.kind, BoundKind::kCrlbStaticAccumulated);
  EXPECT_EQ(bound.draws, RangeDraws::kOwnDraws);
  EXPECT_NEAR(bound.all_data_single_rmse_m, legacy.single_snapshot_rmse_m, 1e-12);
  EXPECT_NEAR(bound.single_rmse_m / bound.all_data_single_rmse_m, 1.24, 0.02);  // docs/algorithms.md §1.3.1
  s.world.source = config::WorldSource::kMrclam;
  EXPECT_EQ(run_bound(world, s, legacy).kind, BoundKind::kNone);
  s.world.source = config::WorldSource::kGenerated;
  s.algorithm.name = "pose_ekf";  // runs on MRCLAM data only; its row says why it has no bound
  const RunBound none = run_bound(world, s, legacy);
  EXPECT_EQ(none.kind, BoundKind::kNone);
  EXPECT_FALSE(none.reason.empty());
  EXPECT_TRUE(std::isnan(none.rmse_at(0)));
}

}  // namespace
}  // namespace swarmloc::world
