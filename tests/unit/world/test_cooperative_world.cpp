// The measurements the world generates for the Atanasov et al., Leng et al. and Calafiore et al. estimators:
// relative positions, reflected paths, proportional ranges, target readings and field readings, and the
// scoring of a field.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "eigen_gtest.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/config/scenario_models.hpp"
#include "swarmloc/models/multipath.hpp"
#include "swarmloc/world/bound.hpp"
#include "swarmloc/world/metrics.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::world {
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
TEST(CooperativeWorld, AffineRangesCarryTheStdOfTheirDistance) {
  const auto scenario = scenario_named(
      "default.yaml", {"noise.range_model=affine", "noise.range_std_m=0.05", "noise.range_factor=0.02"});
  const World world = build_world(scenario);
  int ranges = 0;
  for (AgentId i = 0; i < world.size(); ++i) {
    for (const auto& r : generate_batch(world, scenario, i, 0).ranges) {
      const double distance =
          (world.truth[static_cast<std::size_t>(i)] - world.truth[static_cast<std::size_t>(r.peer)]).norm();
      EXPECT_NEAR(r.std_m, 0.05 + 0.02 * distance, 1e-12);
      ++ranges;
    }
  }
  EXPECT_GT(ranges, world.size());
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
  const auto sensor = config::field_sensor(exact);
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
}  // namespace
}  // namespace swarmloc::world
