#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "eigen_gtest.hpp"
#include "swarmloc/estimators/consensus/joint_field.hpp"

namespace swarmloc::estimators::consensus {
namespace {

FieldSensor ten_by_ten(FieldSensing sensing) {
  FieldSensor sensor;  // 10 × 10 cells of 10 m, r_s = 15 m
  sensor.sensing = sensing;
  return sensor;
}

TEST(FieldSensing, ContinuousRowIsTheTentOfEachCellCentreAndMovesLittleWithTheSensor) {
  const FieldSensor sensor = ten_by_ten(FieldSensing::kContinuous);
  const Vec2 at(23.0, 41.0);
  const VecX h = field_observation_row(sensor, at);
  ASSERT_EQ(h.size(), 100);
  // Cell (row 4, col 2) has its centre at (25, 45): distance √20, weight 1 − √20/15.
  EXPECT_NEAR(h(4 * 10 + 2), 1.0 - std::sqrt(20.0) / 15.0, 1e-12);
  EXPECT_EQ(h(9 * 10 + 9), 0.0);  // (95, 95) is beyond r_s
  // Lipschitz with constant √cells / r_s: a 1 mm move changes the row by well under 1e-3.
  EXPECT_LT((field_observation_row(sensor, at + Vec2(1e-3, 0.0)) - h).norm(), 1e-3);
}

TEST(FieldSensing, CellBasedRowJumpsAtACellBoundaryAndIsConstantInsideACell) {
  const FieldSensor sensor = ten_by_ten(FieldSensing::kCellBased);
  const Vec2 on_boundary(30.0, 47.0);  // the line between columns 2 and 3
  const VecX left = field_observation_row(sensor, on_boundary - Vec2(1e-6, 0.0));
  const VecX right = field_observation_row(sensor, on_boundary + Vec2(1e-6, 0.0));
  EXPECT_GT((right - left).norm(), 0.5);
  EXPECT_EQ(field_observation_row(sensor, on_boundary), right);  // a boundary point belongs to the right
  EXPECT_EQ(field_observation_row(sensor, Vec2(31.0, 41.0)), field_observation_row(sensor, Vec2(39.0, 49.0)));
  EXPECT_EQ(sensor.grid.cell_of(Vec2(-5.0, 500.0)), 9 * 10 + 0);  // clamped onto the grid
}

/// A sensor that knows its position and hears no neighbour: after s readings z = hᵀy + v of a constant
/// field its estimate is (s h hᵀ/V + s δ I)⁻¹ Σ h z / V — the regularized least squares of eq. (10).
TEST(JointLocalizationField, LoneSensorComputesTheRegularizedEstimateOfEquationTen) {
  JointFieldParams params;
  params.sensor.grid.columns = 2;
  params.sensor.grid.rows = 1;
  params.sensor.radius_m = 30.0;
  params.reference_position_m = Vec2(3.0, 1.0);
  params.delta = 0.5;
  params.localize = false;
  AgentSetup setup;
  setup.initial_guess_m = Vec2(4.0, 2.0);  // in the reference's frame: the sensor is at (7, 3)
  JointLocalizationField sensor(setup, params);
  EXPECT_MATRIX_NEAR(sensor.sensing_position(), Vec2(7.0, 3.0), 1e-15);
  const VecX h = field_observation_row(params.sensor, Vec2(7.0, 3.0));
  const double variance = 0.25;
  MeasurementBatch batch;
  Mat2 covariance = Mat2::Identity();
  covariance(0, 0) = variance;
  Inbox inbox;
  for (const double z : {1.0, 3.0}) {
    batch.targets = {TargetObservation{0, Vec2(z, 0.0), covariance, kFieldReading}};
    sensor.step(StepInput{0, &batch, &inbox});
  }
  const MatX normal = 2.0 * h * h.transpose() / variance + 2.0 * 0.5 * MatX::Identity(2, 2);
  const VecX expected = normal.ldlt().solve(h * (4.0 / variance));
  EXPECT_MATRIX_NEAR(sensor.field_estimate(), expected, 1e-12);
}

TEST(JointLocalizationField, NonFinitePriorsAndReadingsAreSkippedNotFused) {
  JointFieldParams params;
  params.sensor.grid.columns = 3;
  params.sensor.grid.rows = 3;
  AgentSetup setup;
  setup.initial_guess_m = Vec2(15.0, 15.0);
  params.localize = false;
  JointLocalizationField sensor(setup, params);
  Inbox inbox;
  MatX poisoned = MatX::Identity(9, 9);
  poisoned(4, 4) = std::numeric_limits<double>::infinity();
  inbox.information.push_back({1, 0, InformationMessage{0, VecX::Ones(9), poisoned}});
  MeasurementBatch batch;
  batch.neighbours = {1};
  batch.targets = {TargetObservation{0, Vec2(std::nan(""), 0.0), Mat2::Identity(), kFieldReading},
                   TargetObservation{0, Vec2(2.0, 0.0), Mat2::Identity(), kFieldReading}};
  const StepOutput out = sensor.step(StepInput{0, &batch, &inbox});
  EXPECT_EQ(out.diagnostics.neighbours_skipped, 1);
  EXPECT_EQ(out.diagnostics.neighbours_used, 0);
  ASSERT_TRUE(out.outbox.information.has_value());
  EXPECT_TRUE(out.outbox.information->info_mat.allFinite());
  EXPECT_TRUE(sensor.field_estimate().allFinite());
  EXPECT_GT(sensor.field_estimate().maxCoeff(), 0.0);  // the finite reading was used
}

TEST(JointLocalizationField, RejectsANonPositiveDeltaAndAnEmptyGrid) {
  JointFieldParams params;
  params.delta = 0.0;
  EXPECT_THROW(JointLocalizationField(AgentSetup{}, params), std::invalid_argument);
  params.delta = 1e-3;
  params.sensor.grid.rows = 0;
  EXPECT_THROW(JointLocalizationField(AgentSetup{}, params), std::invalid_argument);
}

}  // namespace
}  // namespace swarmloc::estimators::consensus
