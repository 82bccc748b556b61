#include "swarmloc/config/scenario_models.hpp"

namespace swarmloc::config {

TargetModel target_model(const Scenario& s) {
  TargetModel model;
  if (s.world.target_motion == TargetMotion::kStatic) return model;
  const double tau = 1.0 / s.run.rate_hz;
  model.dim = 4;
  model.F = MatX::Identity(4, 4);
  model.F.topRightCorner<2, 2>() = tau * Mat2::Identity();
  model.W = MatX(4, 4);
  model.W << tau * tau * tau / 3.0 * Mat2::Identity(), tau * tau / 2.0 * Mat2::Identity(),
      tau * tau / 2.0 * Mat2::Identity(), tau * Mat2::Identity();
  model.W *= s.world.target_accel_psd;
  return model;
}

estimators::consensus::FieldSensor field_sensor(const Scenario& s) {
  estimators::consensus::FieldSensor sensor;
  sensor.grid.columns = s.world.field_cells_per_side;
  sensor.grid.rows = s.world.field_cells_per_side;
  sensor.grid.cell_m = s.world.area_m / s.world.field_cells_per_side;
  sensor.sensing = s.world.field_sensing == FieldSensing::kContinuous
                       ? estimators::consensus::FieldSensing::kContinuous
                       : estimators::consensus::FieldSensing::kCellBased;
  sensor.radius_m = s.world.field_sensing_radius_m;
  return sensor;
}

}  // namespace swarmloc::config
