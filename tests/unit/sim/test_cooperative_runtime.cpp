// The 002/003/004 estimators driven by the shared runtime: world measurements of every kind, validation
// of the information, consensus and belief families, and in-process runs of the shipped scenarios.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>

#include "eigen_gtest.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/estimators/consensus/cooperative.hpp"
#include "swarmloc/models/multipath.hpp"
#include "swarmloc/runtime/agent_runtime.hpp"
#include "swarmloc/sim/simulator.hpp"
#include "swarmloc/world/metrics.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::sim {
namespace {

const std::string kScenarios = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/";

config::Scenario scenario_named(const std::string& file, const std::vector<std::string>& overrides = {}) {
  return config::load_scenario(kScenarios + file, overrides);
}

TEST(CooperativeWorld, RelativeMeasurementsAreOneDrawSharedWithOppositeSigns) {
  const auto scenario = scenario_named("jacobi.yaml");
  const World world = build_world(scenario);
  const auto batch0 = generate_batch(world, scenario, 0, 3);
  ASSERT_FALSE(batch0.relative.empty());
  EXPECT_TRUE(batch0.ranges.empty()) << "jacobi consumes relative positions only";
  for (const auto& m : batch0.relative) {
    const auto other = generate_batch(world, scenario, m.peer, 3);
    const auto it = std::find_if(other.relative.begin(), other.relative.end(),
                                 [](const estimators::RelativeMeasurement& r) { return r.peer == 0; });
    ASSERT_NE(it, other.relative.end());
    EXPECT_EQ(it->delta_m, Vec2(-m.delta_m)) << "link 0-" << m.peer;
    const Vec2 truth = world.truth[static_cast<std::size_t>(m.peer)] - world.truth[0];
    EXPECT_LT((m.delta_m - truth).norm(), 6.0 * scenario.noise.relative_std_m);
    EXPECT_NEAR(m.covariance(0, 0), 0.01, 1e-15);
  }
  // Fresh noise per step by default; one snapshot with noise.draw = once.
  EXPECT_NE(generate_batch(world, scenario, 0, 4).relative[0].delta_m, batch0.relative[0].delta_m);
  const auto once = scenario_named("jacobi.yaml", {"noise.draw=once"});
  const World world_once = build_world(once);
  EXPECT_EQ(generate_batch(world_once, once, 0, 4).relative[0].delta_m,
            generate_batch(world_once, once, 0, 9).relative[0].delta_m);
}

TEST(CooperativeWorld, NoiseFreeReflectedPathsSatisfyEquationOneToMachinePrecision) {
  const auto scenario =
      scenario_named("multipath_bp.yaml", {"noise.range_std_m=1e-300", "noise.doa_error_deg=0"});
  const World world = build_world(scenario);
  ASSERT_EQ(world.walls.size(), 2U);
  int paths = 0;
  for (AgentId i = 0; i < world.size(); ++i) {
    const auto batch = generate_batch(world, scenario, i, 0);
    for (const auto& path : batch.paths) {
      // d_ji = g(θ_ij, θ_ji)ᵀ (s_i − s_j): aoa_here = θ_ji (at S_i), aoa_there = θ_ij (at S_j).
      const Vec2 g = models::path_direction(path.aoa_there_rad, path.aoa_here_rad);
      const Vec2 difference =
          world.truth[static_cast<std::size_t>(i)] - world.truth[static_cast<std::size_t>(path.peer)];
      EXPECT_NEAR(path.length_m, g.dot(difference), 1e-9 * std::max(1.0, path.length_m));
      EXPECT_GT(path.length_m, difference.norm()) << "a reflection is longer than the direct path";
      ++paths;
    }
  }
  EXPECT_GT(paths, 2 * world.size());
}

TEST(CooperativeWorld, SharedProportionalRangesAreEqualAtBothEnds) {
  const auto scenario = scenario_named("dgbb.yaml");
  const World world = build_world(scenario);
  const auto a = generate_batch(world, scenario, 6, 0);
  ASSERT_FALSE(a.ranges.empty());
  EXPECT_FALSE(a.fix.has_value()) << "gradient anchors know their position from the start";
  for (const auto& r : a.ranges) {
    const auto b = generate_batch(world, scenario, r.peer, 0);
    const auto back =
        std::find_if(b.ranges.begin(), b.ranges.end(), [](const auto& m) { return m.peer == 6; });
    ASSERT_NE(back, b.ranges.end());
    EXPECT_EQ(back->range_m, r.range_m);
    const double distance = (world.truth[6] - world.truth[static_cast<std::size_t>(r.peer)]).norm();
    EXPECT_NEAR(r.std_m, 0.01 * distance, 1e-15);
  }
}

AgentRuntime bp_runtime() {
  estimators::AgentSetup setup{0, false, Vec2(5.0, 5.0)};
  AgentRuntimeParams params;
  params.absurd_position_bound_m = 1e5;
  auto scenario = scenario_named("multipath_bp.yaml");
  const World world = build_world(scenario);
  return AgentRuntime(make_agent_estimator(scenario, world, 0), setup, {1, 2}, params);
}

TEST(CooperativeWorld, TargetReadingsAreTheTargetPlusNoiseForTheSensorsInRange) {
  const auto scenario =
      scenario_named("dle.yaml", {"world.target_sensing_radius_m=15", "noise.target_std_m=0.5"});
  const World world = build_world(scenario);
  ASSERT_TRUE(world.estimates_target());
  const Vec2 target(scenario.world.target_x_m, scenario.world.target_y_m);
  int readers = 0;
  for (AgentId i = 0; i < world.size(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    EXPECT_EQ(world.setup_of(i).initial_guess_m, world.truth[k]) << "sensors know their positions";
    EXPECT_EQ(world.scored_truth(i), target);
    EXPECT_TRUE(world.scored(i));
    const bool in_range = (world.truth[k] - target).norm() <= 15.0;
    readers += in_range ? 1 : 0;
    const auto batch = generate_batch(world, scenario, i, 0);
    EXPECT_TRUE(batch.ranges.empty() && batch.relative.empty() && batch.paths.empty());
    ASSERT_EQ(batch.targets.size(), in_range ? 1U : 0U) << "sensor " << i;
  }
  EXPECT_GT(readers, 0);
  EXPECT_LT(readers, world.size());
  // Linear readings (σ = 0.5 m): mean over 400 steps within 4 σ/√400 of the target, per-axis variance σ².
  const AgentId reader = [&] {
    for (AgentId i = 0;; ++i) {
      if ((world.truth[static_cast<std::size_t>(i)] - target).norm() <= 15.0) return i;
    }
  }();
  Vec2 sum = Vec2::Zero();
  double squares = 0.0;
  constexpr int kSteps = 400;
  for (int step = 0; step < kSteps; ++step) {
    const auto reading = generate_batch(world, scenario, reader, step).targets.at(0);
    EXPECT_EQ(reading.kind, 0);
    EXPECT_EQ(reading.covariance, Mat2(0.25 * Mat2::Identity()));
    sum += reading.value;
    squares += (reading.value - target).squaredNorm();
  }
  EXPECT_LT((sum / kSteps - target).norm(), 4.0 * 0.5 * std::sqrt(2.0 / kSteps));
  EXPECT_NEAR(squares / (2 * kSteps), 0.25, 0.05);
  // Range and bearing from the sensor, noise-free here.
  const auto exact =
      scenario_named("dle.yaml", {"world.target_sensing=range_bearing", "noise.target_std_m=1e-300",
                                  "noise.target_bearing_std_rad=1e-6"});
  const World exact_world = build_world(exact);
  const auto reading = generate_batch(exact_world, exact, 3, 0).targets.at(0);
  const Vec2 offset = target - exact_world.truth[3];
  EXPECT_EQ(reading.kind, 1);
  EXPECT_NEAR(reading.value(0), offset.norm(), 1e-12);
  EXPECT_NEAR(reading.value(1), std::atan2(offset.y(), offset.x()), 1e-5);
}

TEST(CooperativeWorld, TheTargetMovesAsADoubleIntegrator) {
  // Without process noise the target moves by τ v per step exactly; with it, reproducibly per seed.
  const auto still = scenario_named("dle_tracking.yaml", {"world.target_accel_psd=0"});
  World world = build_world(still);
  ASSERT_EQ(world.target.size(), 4);
  for (std::int64_t step = 1; step <= 50; ++step) advance_truth(world, still, step);
  EXPECT_MATRIX_NEAR(world.target, VecX((VecX(4) << 15.0, 12.5, 1.0, 0.5).finished()), 1e-12);

  const auto noisy = scenario_named("dle_tracking.yaml", {"world.target_accel_psd=1"});
  World a = build_world(noisy);
  World b = build_world(noisy);
  for (std::int64_t step = 1; step <= 50; ++step)
    advance_truth(a, noisy, step), advance_truth(b, noisy, step);
  EXPECT_MATRIX_NEAR(a.target, b.target, 0.0);
  EXPECT_GT((a.target - world.target).norm(), 0.1);
}

TEST(CooperativeWorld, TheStaticTargetBoundIsTheCentralizedEstimateFromEveryReading) {
  const auto linear = scenario_named("dle.yaml", {"noise.target_std_m=2"});
  const World world = build_world(linear);
  // N readings of σ = 2 m per axis: tr((N/σ² I)⁻¹) = 2σ²/N.
  EXPECT_NEAR(scenario_crlb(world, linear).single_snapshot_rmse_m, std::sqrt(8.0 / world.size()), 1e-12);
  // Range and bearing: J = Σ hᵢ'ᵀ V⁻¹ hᵢ' with the Jacobian h' = d(range, bearing)/d(target) taken here by
  // central differences.
  const auto rb = scenario_named("dle.yaml", {"world.target_sensing=range_bearing"});
  const World rb_world = build_world(rb);
  const Vec2 target = rb_world.target.head<2>();
  Mat2 information = Mat2::Zero();
  const Mat2 V_inverse = Vec2(1.0, 1.0 / (0.05 * 0.05)).asDiagonal();
  for (const Vec2& sensor : rb_world.truth) {
    const auto h = [&](const Vec2& y) {
      const Vec2 d = y - sensor;
      return Vec2(d.norm(), std::atan2(d.y(), d.x()));
    };
    Mat2 jacobian;
    for (int axis = 0; axis < 2; ++axis) {
      const Vec2 step = 1e-6 * Vec2::Unit(axis);
      jacobian.col(axis) = (h(target + step) - h(target - step)) / 2e-6;
    }
    information += jacobian.transpose() * V_inverse * jacobian;
  }
  EXPECT_NEAR(scenario_crlb(rb_world, rb).single_snapshot_rmse_m, std::sqrt(information.inverse().trace()),
              1e-8);
  EXPECT_TRUE(std::isnan(
      scenario_crlb(build_world(scenario_named("dle_tracking.yaml")), scenario_named("dle_tracking.yaml"))
          .single_snapshot_rmse_m))
      << "no bound for a moving target";
}

TEST(CooperativeWorld, FieldReadingsAreTheModelRowTimesTheFieldAtTheTruePosition) {
  const auto exact = scenario_named("joint_field.yaml", {"noise.field_std=1e-300"});
  const World world = build_world(exact);
  const auto sensor = field_sensor(exact);
  ASSERT_EQ(world.field.size(), 25);
  EXPECT_EQ(sensor.grid.cell_m, 8.0);
  EXPECT_FALSE(world.estimates_target()) << "joint_field agents are scored on their own positions";
  for (AgentId i = 0; i < world.size(); ++i) {
    const auto batch = generate_batch(world, exact, i, 0);
    EXPECT_FALSE(batch.relative.empty()) << "Jacobi's relative positions";
    ASSERT_EQ(batch.targets.size(), 1U);
    const auto& reading = batch.targets[0];
    EXPECT_EQ(reading.kind, estimators::consensus::kFieldReading);
    const double expected =
        estimators::consensus::field_observation_row(sensor, world.truth[static_cast<std::size_t>(i)])
            .dot(world.field);
    EXPECT_NEAR(reading.value(0), expected, 1e-12);
  }
  // The field belongs to the world (the seed), not to a Monte Carlo trial; its values are N(0, σ²).
  EXPECT_MATRIX_NEAR(build_world(exact, 3).field, world.field, 0.0);
  EXPECT_GT((build_world(scenario_named("joint_field.yaml", {"seed=2"})).field - world.field).norm(), 0.1);
  EXPECT_GT(world.field.cwiseAbs().maxCoeff(), 0.3);
  EXPECT_LT(world.field.cwiseAbs().maxCoeff(), 5.0);
  // Noisy readings scatter by noise.field_std around the model.
  const auto noisy = scenario_named("joint_field.yaml");
  double squares = 0.0;
  const double model = estimators::consensus::field_observation_row(sensor, world.truth[0]).dot(world.field);
  for (int step = 0; step < 400; ++step)
    squares += std::pow(generate_batch(world, noisy, 0, step).targets.at(0).value(0) - model, 2);
  EXPECT_NEAR(std::sqrt(squares / 400), 0.1, 0.015);
}

TEST(CooperativeWorld, TheFieldErrorIsTheRootMeanSquareOverAgentsAndCells) {
  const auto scenario =
      scenario_named("joint_field.yaml", {"world.agents=3", "world.anchors=1", "world.comm_radius_m=100"});
  const World world = build_world(scenario);
  std::vector<std::optional<estimators::Estimate>> estimates(3);
  for (std::size_t i = 0; i < 3; ++i) {
    estimators::Estimate estimate;
    estimate.mean_m = world.truth[i];
    estimate.covariance = Mat2::Identity();
    estimate.valid = true;
    estimate.field = world.field;
    estimates[i] = estimate;
  }
  estimates[1]->field.array() += 0.3;   // 0.09 per cell
  estimates[2]->field(0) += 5.0;        // 25 / 25 cells = 1 per cell
  estimates[0]->field = VecX::Zero(3);  // the wrong size: not scored
  const ErrorStats stats = score(world, estimates);
  EXPECT_EQ(stats.field_scored, 2);
  EXPECT_NEAR(stats.field_rmse, std::sqrt((0.09 + 1.0) / 2.0), 1e-12);
  EXPECT_EQ(stats.scored, 2) << "positions: the non-anchors, as for any localization";
}

TEST(CooperativeRuntime, HostileInformationConsensusAndBeliefSamplesAreRejectedPerReason) {
  AgentRuntime runtime = bp_runtime();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::uint32_t seq = 0;
  auto header = [&](AgentId sender) { return Header{sender, seq++, 0, 0, 0}; };

  estimators::BeliefMessage belief;
  belief.mean_m = Vec2(1.0, 2.0);
  belief.information = Mat2::Identity();
  EXPECT_TRUE(runtime.on_belief(header(1), belief));
  auto nan_belief = belief;
  nan_belief.mean_m.x() = nan;
  EXPECT_FALSE(runtime.on_belief(header(1), nan_belief));
  auto non_psd = belief;
  non_psd.information << 1.0, 3.0, 3.0, 1.0;
  EXPECT_FALSE(runtime.on_belief(header(1), non_psd));
  auto absurd = belief;
  absurd.mean_m = Vec2(1e9, 0.0);
  EXPECT_FALSE(runtime.on_belief(header(1), absurd));
  // Exact GaBP's contributions: each a PSD message, at most one per neighbour.
  auto with_contributions = belief;
  with_contributions.contributions = {{0, Mat2::Identity(), Vec2(1.0, 0.0)},
                                      {2, Mat2::Identity() * 0.5, Vec2::Zero()}};
  const std::uint32_t newest_from_1 = seq;
  EXPECT_TRUE(runtime.on_belief(header(1), with_contributions));
  auto nan_contribution = with_contributions;
  nan_contribution.contributions[1].info_vec.y() = nan;
  EXPECT_FALSE(runtime.on_belief(header(1), nan_contribution));
  auto non_psd_contribution = with_contributions;
  non_psd_contribution.contributions[0].information << 1.0, 3.0, 3.0, 1.0;
  EXPECT_FALSE(runtime.on_belief(header(1), non_psd_contribution));
  auto absurd_contribution = with_contributions;
  absurd_contribution.contributions[0].information *= 1e40;
  EXPECT_FALSE(runtime.on_belief(header(1), absurd_contribution));
  auto repeated = with_contributions;
  repeated.contributions[1].from = 0;
  EXPECT_FALSE(runtime.on_belief(header(1), repeated));
  auto negative_sender = with_contributions;
  negative_sender.contributions[0].from = -1;
  EXPECT_FALSE(runtime.on_belief(header(1), negative_sender));

  estimators::ConsensusMessage consensus;
  consensus.values = {1.0, 2.0};
  EXPECT_TRUE(runtime.on_consensus(header(2), consensus));
  auto inf_consensus = consensus;
  inf_consensus.values[1] = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(runtime.on_consensus(header(2), inf_consensus));
  auto long_consensus = consensus;
  long_consensus.values.assign(1000, 0.0);
  EXPECT_FALSE(runtime.on_consensus(header(2), long_consensus));
  auto negative_round = consensus;
  negative_round.round = -1;
  EXPECT_FALSE(runtime.on_consensus(header(2), negative_round));

  estimators::InformationMessage information;
  information.info_vec = VecX::Ones(2);
  information.info_mat = MatX::Identity(2, 2);
  EXPECT_TRUE(runtime.on_information(header(2), information));
  auto wrong_size = information;
  wrong_size.info_mat = MatX::Identity(3, 3);
  EXPECT_FALSE(runtime.on_information(header(2), wrong_size));
  auto negative_world_step = information;  // −1 means "none"; below it is malformed
  negative_world_step.world_step = -2;
  EXPECT_FALSE(runtime.on_information(header(2), negative_world_step));
  auto asymmetric = information;
  asymmetric.info_mat(0, 1) = 5.0;
  EXPECT_FALSE(runtime.on_information(header(2), asymmetric));
  EXPECT_FALSE(runtime.on_belief(header(7), belief)) << "agent 7 is not a neighbour";
  EXPECT_FALSE(runtime.on_belief(Header{1, newest_from_1, 0, 0, 0}, belief))
      << "the same seq as the newest from 1";
  EXPECT_FALSE(runtime.on_consensus(Header{2, 1, 0, 0, 0}, consensus)) << "older than the newest from 2";

  const auto& reasons = runtime.rejected_by_reason();
  auto count = [&](RejectReason r) { return reasons[static_cast<std::size_t>(r)]; };
  EXPECT_EQ(count(RejectReason::kNonFinite), 3U);
  EXPECT_EQ(count(RejectReason::kNotSymmetricPsd), 3U);
  EXPECT_EQ(count(RejectReason::kAbsurdMagnitude), 2U);
  EXPECT_EQ(count(RejectReason::kMalformed), 6U);
  EXPECT_EQ(count(RejectReason::kUnknownSender), 1U);
  EXPECT_EQ(count(RejectReason::kDuplicate), 1U);
  EXPECT_EQ(count(RejectReason::kReordered), 1U);
  // The runtime keeps stepping on the accepted samples only.
  const auto publication = runtime.step(0);
  ASSERT_TRUE(publication.outbox.belief.has_value());
  EXPECT_TRUE(publication.outbox.belief->mean_m.allFinite());
}

TEST(CooperativeRuntime, ASupersededBatchKeepsItsRelativeSamples) {
  // Free run: batches 0 and 1 both arrive before the agent steps. Jacobi from one anchor neighbour at
  // the origin gives x = −s̄, so the carried-over sample shows in the mean: s̄ = (1 + 3)/2, not 3.
  estimators::AgentSetup setup{0, false, Vec2(5.0, 5.0)};
  AgentRuntimeParams params;
  params.absurd_position_bound_m = 1e5;
  AgentRuntime runtime(estimators::make_cooperative_estimator("jacobi", setup, {}), setup, {1}, params);
  estimators::StateMessage anchor;
  anchor.anchor = true;
  ASSERT_TRUE(runtime.on_state(Header{1, 0, 0, 0, 0}, anchor));
  for (const double sample : {1.0, 3.0}) {
    estimators::MeasurementBatch batch;
    batch.world_step = sample > 2.0 ? 1 : 0;
    batch.relative.push_back({1, Vec2(sample, 0.0), Mat2::Identity() * 0.01});
    batch.ranges.push_back({1, sample, 1.0});
    runtime.on_batch(Header{kOrchestratorId, 0, batch.world_step, 0, 0}, batch);
  }
  runtime.step(0);
  EXPECT_NEAR(runtime.estimate().mean_m.x(), -2.0, 1e-12);
  EXPECT_NEAR(runtime.estimate().mean_m.y(), 0.0, 1e-12);
}

TEST(CooperativeRuntime, ASupersededBatchKeepsItsTargetReadings) {
  // Free run: a static target's readings (1, 0) and (3, 0) arrive in batches 0 and 1 before the sensor
  // steps; the DLE sums both (equal weights): ŷ = (2, 0), not (3, 0).
  const estimators::AgentSetup setup{0, false, Vec2(5.0, 5.0)};
  AgentRuntimeParams params;
  params.absurd_position_bound_m = 1e5;
  AgentRuntime runtime(estimators::make_cooperative_estimator("dle", setup, {}), setup, {}, params);
  for (const double reading : {1.0, 3.0}) {
    estimators::MeasurementBatch batch;
    batch.world_step = reading > 2.0 ? 1 : 0;
    batch.targets.push_back({0, Vec2(reading, 0.0), Mat2::Identity(), 0});
    runtime.on_batch(Header{kOrchestratorId, 0, batch.world_step, 0, 0}, batch);
  }
  runtime.step(0);
  EXPECT_NEAR(runtime.estimate().mean_m.x(), 2.0, 1e-12);
  EXPECT_NEAR(runtime.estimate().mean_m.y(), 0.0, 1e-12);
}

TEST(CooperativeSimulation, JacobiApproachesTheBlueBoundOfItsRelativeMeasurements) {
  const auto record = run_simulation(scenario_named("jacobi.yaml"));
  const auto& first = record.metrics.front().errors;
  const auto& last = record.metrics.back().errors;
  const double bound =
      record.crlb.single_snapshot_rmse_m / std::sqrt(static_cast<double>(record.metrics.size()));
  EXPECT_LT(last.rmse_m, 0.1 * first.rmse_m);
  // Jacobi's fixed point is the BLUE of all samples so far, whose expected RMSE is the accumulated
  // bound; one realization over 22 agents scatters by ±25 % around it (seeds 1–5: 0.75–1.22).
  EXPECT_GT(last.rmse_m, 0.6 * bound);
  EXPECT_LT(last.rmse_m, 1.6 * bound);
  EXPECT_EQ(last.scored, 22);
}

// run.agent_steps_per_world_step: agents that exchange several times per measurement drain Jacobi's prior
// transient (150 agents, one anchor, step 50: 0.197 / 0.024 / 0.0078 m in rounds with 1 / 10 / 30 steps
// per world step, 0.260 / 0.0087 / 0.0080 m on agent clocks), and every agent step is one exchange.
// config (which must not depend on the estimators) keeps its own list of the algorithms that take extra
// agent steps; it must hold the estimators' cooperative family (and dml, test_algorithm_registry.cpp).
TEST(CooperativeSimulation, TheExchangeOnlyAlgorithmsIncludeTheCooperativeFamily) {
  const auto& exchange_only = config::exchange_only_algorithms();
  for (const auto& name : estimators::cooperative_algorithms())
    EXPECT_NE(std::find(exchange_only.begin(), exchange_only.end(), name), exchange_only.end()) << name;
}

TEST(CooperativeSimulation, SeveralAgentStepsPerWorldStepDrainJacobisTransient) {
  const std::vector<std::string> sparse{"world.agents=150",       "world.anchors=1", "world.area_m=120",
                                        "world.comm_radius_m=20", "run.steps=50",    "clock.drift_ppm=100"};
  auto final_rmse_and_sent = [&](int steps, const std::string& clock) {
    auto overrides = sparse;
    overrides.push_back("run.agent_steps_per_world_step=" + std::to_string(steps));
    overrides.push_back("run.sim_clock=" + clock);
    const auto record = run_simulation(scenario_named("jacobi.yaml", overrides));
    EXPECT_EQ(record.final_metrics()->errors.scored, 149);
    return std::pair{record.final_metrics()->errors.rmse_m, static_cast<double>(link_totals(record).sent)};
  };
  const auto [rounds_1, rounds_1_sent] = final_rmse_and_sent(1, "rounds");
  const auto [rounds_10, rounds_10_sent] = final_rmse_and_sent(10, "rounds");
  const auto [rounds_30, rounds_30_sent] = final_rmse_and_sent(30, "rounds");
  const auto [agents_1, agents_1_sent] = final_rmse_and_sent(1, "agents");
  const auto [agents_10, agents_10_sent] = final_rmse_and_sent(10, "agents");
  const auto [agents_30, agents_30_sent] = final_rmse_and_sent(30, "agents");
  EXPECT_GT(rounds_1, 4.0 * rounds_10);
  EXPECT_GT(rounds_10, rounds_30);
  EXPECT_GT(agents_1, 4.0 * agents_10);
  // Converged, both schedules sit at the same fixed point (the BLUE of the samples so far).
  EXPECT_NEAR(agents_30, rounds_30, 0.1 * rounds_30);
  EXPECT_EQ(rounds_10_sent, 10 * rounds_1_sent);
  // Agent clocks: ten ticks per period, give or take the first period's phase and the drift.
  EXPECT_NEAR(agents_10_sent, 10 * agents_1_sent, 0.02 * agents_10_sent);
  EXPECT_EQ(rounds_30_sent, 30 * rounds_1_sent);
  EXPECT_NEAR(agents_30_sent, 30 * agents_1_sent, 0.02 * agents_30_sent);
}

// dml_track's belief messages carry the sender's draws of its newest step; with three exchanges per world
// step each draw arrives three times and must still count once (docs/algorithms.md §9.8). ea2, 60 steps:
// final NEES 3.42 with one exchange, 3.44 with three; adding each copy instead gives 19 and 172.
TEST(CooperativeSimulation, DmlTrackCountsARepeatedDrawOnceWithSeveralExchangesPerWorldStep) {
  auto final_errors = [](int exchanges) {
    return run_simulation(
               scenario_named("ea2.yaml", {"algorithm.name=dml_track", "run.steps=60",
                                           "run.agent_steps_per_world_step=" + std::to_string(exchanges)}))
        .final_metrics()
        ->errors;
  };
  const auto once = final_errors(1);
  const auto thrice = final_errors(3);
  EXPECT_LT(thrice.nees, 1.2 * once.nees);
  EXPECT_LT(thrice.rmse_m, 1.05 * once.rmse_m);
  std::printf("[ dml_track ] ea2, 60 steps: final NEES %.2f with one exchange per step, %.2f with three\n",
              once.nees, thrice.nees);
}

// algorithm.local_bb_difference on 004's Table I lattice (10 × 10 with diagonals, noiseless, no trust
// region): eq. (15) as printed (own_move) converges, the [E-6] reading (gradient_change) diverges.
TEST(CooperativeSimulation, LocalBbAsPrintedConvergesWhereTheGradientChangeReadingDiverges) {
  auto final_rmse = [](const std::string& difference) {
    const auto record = run_simulation(scenario_named(
        "dgbb.yaml",
        {"world.agents=100", "world.comm_radius_m=0.16", "noise.range_factor=0", "algorithm.name=local_bb",
         "algorithm.max_move_fraction=0", "run.steps=1000", "algorithm.local_bb_difference=" + difference}));
    return record.final_metrics()->errors.rmse_m;
  };
  EXPECT_LT(final_rmse("own_move"), 1e-4);  // 7.8e-6 m at step 1000
  const double gradient_change = final_rmse("gradient_change");
  EXPECT_FALSE(gradient_change < 1e-2) << gradient_change;  // diverged (or NaN)
}

TEST(CooperativeSimulation, DgbbConvergesToTheNoisyRangesOptimum) {
  const auto record = run_simulation(scenario_named("dgbb.yaml"));
  const auto& last = record.metrics.back().errors;
  // The minimizer of f is off the truth by the range noise (ν_d = 1 % of 0.25–0.5 m links): a few mm.
  EXPECT_LT(last.rmse_m, 2.0 * record.crlb.single_snapshot_rmse_m);
  EXPECT_LT(last.rmse_m, 0.2 * record.metrics.front().errors.rmse_m);
}

// dgbb.yaml seed 2 at 20 % loss: without the BB trust region a lost consensus value left ψ near zero, the
// node jumped ~2.5 m on the 1 m grid and DG-BB settled in a fold-over minimum at 0.147 m (0.0030 m
// lossless). With algorithm.max_move_fraction = 0 this test fails.
TEST(CooperativeSimulation, DgbbUnderTwentyPercentLossStaysOutOfFoldOverMinima) {
  const auto lossless = run_simulation(scenario_named("dgbb.yaml", {"seed=2"}));
  const auto lossy = run_simulation(scenario_named("dgbb.yaml", {"seed=2", "network.loss=0.2"}));
  const double reference = lossless.metrics.back().errors.rmse_m;
  EXPECT_LT(reference, 0.01);
  EXPECT_LT(lossy.metrics.back().errors.rmse_m, 1.5 * reference);
  EXPECT_LT(lossy.metrics.back().errors.max_error_m, 0.05);
}

// 002 Thm. 1: the static target's MSE falls toward 0. Averaged over 20 worlds (one realization is a single
// 2-D error shared by all sensors: seeds 1–8 give 0.81–1.64× the bound), the MSE falls at every checkpoint
// and ends near the centralized estimate's from all readings (20 seeds: 1.1×).
TEST(CooperativeSimulation, DleMseFallsTowardZeroAndReachesTheCentralizedBound) {
  constexpr int kSeeds = 20;
  const std::array<std::size_t, 5> checkpoints{0, 9, 19, 49, 99};
  std::array<double, 5> mse{};
  double bound_mse = 0.0;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    // Without the free run's settle rounds: the checkpoints compare the world steps' own figures.
    const auto record =
        run_simulation(scenario_named("dle.yaml", {"seed=" + std::to_string(seed), "run.settle_s=0"}));
    ASSERT_EQ(record.metrics.size(), 100U);
    EXPECT_EQ(record.metrics.back().errors.scored, 30);
    for (std::size_t k = 0; k < checkpoints.size(); ++k)
      mse[k] += std::pow(record.metrics[checkpoints[k]].errors.rmse_m, 2) / kSeeds;
    bound_mse += std::pow(record.metrics.back().crlb_rmse_m, 2) / kSeeds;
  }
  for (std::size_t k = 1; k < checkpoints.size(); ++k)
    EXPECT_LT(mse[k], 0.75 * mse[k - 1]) << "step " << checkpoints[k];
  EXPECT_LT(mse.back(), 0.05 * mse.front());
  EXPECT_LT(mse.back(), 1.5 * bound_mse);
  EXPECT_GT(mse.back(), 0.7 * bound_mse) << "below the bound: the readings' noise is not what it says";
}

// 002 Figs. 1, 3 in the runtime: range and bearing readings, first linearized at the area's centre ~12 m
// from the target; after 150 steps (15 s) every sensor tracks it within decimetres (seeds 1–6: 0.06–0.27 m).
TEST(CooperativeSimulation, DleTracksAMovingTargetFromRangeAndBearing) {
  const auto record = run_simulation(scenario_named("dle_tracking.yaml"));
  const auto& first = record.metrics.front().errors;
  const auto& last = record.metrics.back().errors;
  EXPECT_GT(first.rmse_m, 5.0);
  EXPECT_LT(last.rmse_m, 0.3);
  EXPECT_LT(last.max_error_m, 0.5);
  EXPECT_EQ(last.scored, 30);
}

// In a free run (agent clocks; 100 ppm of drift so that no two agents tick at the same instant) a sensor's
// neighbours' priors are about world steps one ahead or behind its own; the DLE brings each to its reading's
// world step before mixing, which beats both mixing them as they come and synchronous rounds: a sensor that
// steps after a neighbour in the same period mixes that neighbour's update of this world step, so a reading
// travels further per period than in rounds (seeds 1-3: docs/measurements/free-run-spread.md §2.1).
TEST(CooperativeSimulation, FreeRunTrackingDleMixesNeighbourPriorsBroughtToOneWorldStep) {
  const auto late_mean_rmse = [](const RunRecord& record) {
    double sum = 0.0;
    for (std::size_t k = 100; k < record.metrics.size(); ++k) sum += record.metrics[k].errors.rmse_m;
    return sum / static_cast<double>(record.metrics.size() - 100);
  };
  const auto rounds = run_simulation(scenario_named("dle_tracking.yaml"));
  const auto free_run =
      run_simulation(scenario_named("dle_tracking.yaml", {"run.sim_clock=agents", "clock.drift_ppm=100"}));
  ASSERT_EQ(free_run.metrics.size(), 150U);
  EXPECT_LT(late_mean_rmse(free_run), 0.95 * late_mean_rmse(rounds));
  EXPECT_LT(free_run.metrics.back().errors.rmse_m, 0.09);
  EXPECT_EQ(free_run.metrics.back().errors.scored, 30);
}

// 002 Fig. 5 in the runtime (readings from step 10 on, the scenario's warm-up): with the continuous tents the
// field error keeps falling as the sensors localize (step 20: 0.327, step 99: 0.151 per cell); reading the
// containing cell makes the model jump at boundaries and the error stalls (0.7827 → 0.7823). Location error
// is the same in both (Jacobi ignores the field).
TEST(CooperativeSimulation, JointFieldErrorFallsWithContinuousSensingAndStallsWithCellBasedSensing) {
  const auto continuous = run_simulation(scenario_named("joint_field.yaml"));
  const auto cell_based =
      run_simulation(scenario_named("joint_field.yaml", {"world.field_sensing=cell_based"}));
  const auto& smooth = continuous.metrics;
  const auto& jumpy = cell_based.metrics;
  ASSERT_EQ(smooth.size(), 100U);
  EXPECT_EQ(smooth.back().errors.field_scored, 30);
  EXPECT_LT(smooth.back().errors.rmse_m, 0.01);
  EXPECT_LT(smooth.back().errors.field_rmse, 0.6 * smooth[20].errors.field_rmse);
  EXPECT_LT(smooth[20].errors.field_rmse, 0.5 * smooth[0].errors.field_rmse);
  EXPECT_GT(jumpy.back().errors.field_rmse, 0.98 * jumpy[20].errors.field_rmse);
  EXPECT_GT(jumpy.back().errors.field_rmse, 2.0 * smooth.back().errors.field_rmse);
  EXPECT_EQ(jumpy.back().errors.rmse_m, smooth.back().errors.rmse_m);
}

// The warm-up makes the field independent of the timing of the first steps: 1000 ppm of clock drift (agent
// clocks, in process) moved the field error from 0.187 to 0.236 without it, and leaves 0.151 with it. Without
// the warm-up the sensor's early readings are modelled at a position still off by up to 0.7 m.
TEST(CooperativeSimulation, JointFieldWarmupRemovesTheEarlyReadingsBias) {
  const auto field_error = [](const std::vector<std::string>& overrides) {
    return run_simulation(scenario_named("joint_field.yaml", overrides)).metrics.back().errors.field_rmse;
  };
  const double rounds = field_error({});
  const double drifting = field_error({"run.sim_clock=agents", "clock.drift_ppm=1000"});
  const double rounds_without = field_error({"algorithm.field_warmup_steps=0"});
  const double drifting_without =
      field_error({"algorithm.field_warmup_steps=0", "run.sim_clock=agents", "clock.drift_ppm=1000"});
  EXPECT_NEAR(drifting, rounds, 0.02 * rounds);
  EXPECT_GT(drifting_without, 1.15 * rounds_without);
  EXPECT_LT(rounds, 0.9 * rounds_without);
}

// multipath_bp.yaml's angle errors (±1°) move its reflected paths by decimetres, which 003's σ² (path
// length only) ignores: the beliefs' covariances are far too small. algorithm.path_variance=with_doa
// (not in 003) puts the angle errors into each path's variance (bp::path_variances).
TEST(CooperativeSimulation, AngleAwarePathVarianceMakesMultipathBpConsistentAndMoreAccurate) {
  const auto final_step = [](const std::string& path_variance) {
    const auto result = run_monte_carlo(
        scenario_named("multipath_bp.yaml", {"algorithm.path_variance=" + path_variance}), 20, 1);
    return result.steps.back();
  };
  const MonteCarloStep range_only = final_step("range_only");
  const MonteCarloStep with_doa = final_step("with_doa");
  EXPECT_GT(range_only.nees_mean, 100.0) << "covariances that ignore the angle errors";
  // 2 is consistent (two dimensions). Measured 3.07; three times the angle variance gives 1.11.
  EXPECT_GT(with_doa.nees_mean, 2.0);
  EXPECT_LT(with_doa.nees_mean, 4.5);
  EXPECT_LT(with_doa.mse_mean, 0.5 * range_only.mse_mean);
}

// The paths' bound (eq. (1) with exact angles, docs/algorithms.md §5.4) against BP without angle errors: 200
// trials put BP's mean squared error 3 % above it. (Its beliefs are overconfident there, NEES 9.4: they
// count shared evidence twice, [D-4].)
TEST(CooperativeSimulation, WithExactAnglesMultipathBpReachesThePathsCrlb) {
  const auto scenario = scenario_named("multipath_bp.yaml", {"noise.doa_error_deg=0"});
  const auto result = run_monte_carlo(scenario, 100, 1);
  const double bound = scenario_crlb(build_world(scenario), scenario).single_snapshot_rmse_m;
  ASSERT_TRUE(std::isfinite(bound));
  EXPECT_GT(result.steps.back().mse_mean, 0.9 * bound * bound);
  EXPECT_LT(result.steps.back().mse_mean, 1.2 * bound * bound);
}

// algorithm.bp_messages=exact (not in 003, the [D-4] ablation): with cavity messages no evidence returns over
// the edge it came by, so the beliefs' covariances shrink less. Exact angles, 50 trials: NEES 9.38 with 003's
// beliefs, 3.89 with cavity messages (2 is consistent; on this loopy graph Gaussian BP's variances are still
// too small), and the same error (MSE 1.70e-3 and 1.68e-3 m²).
TEST(CooperativeSimulation, ExactGaBpMessagesCutTheBeliefsOverconfidence) {
  const auto final_step = [](const std::string& messages) {
    return run_monte_carlo(scenario_named("multipath_bp.yaml",
                                          {"noise.doa_error_deg=0", "algorithm.bp_messages=" + messages}),
                           50, 1)
        .steps.back();
  };
  const MonteCarloStep beliefs = final_step("beliefs");
  const MonteCarloStep exact = final_step("exact");
  EXPECT_GT(beliefs.nees_mean, 7.0);
  EXPECT_LT(exact.nees_mean, 5.0);
  EXPECT_GT(exact.nees_mean, 2.0);
  EXPECT_LT(exact.mse_mean, 1.05 * beliefs.mse_mean);
}

TEST(CooperativeSimulation, MultipathBpLocalizesEveryAgent) {
  const auto record = run_simulation(scenario_named("multipath_bp.yaml"));
  const auto& last = record.metrics.back().errors;
  EXPECT_EQ(last.scored, 10);
  EXPECT_LT(last.rmse_m, 0.6) << "path-length std 0.5 m, DOA ±1°";
  EXPECT_LT(last.max_error_m, 1.5);
}

}  // namespace
}  // namespace swarmloc::sim
