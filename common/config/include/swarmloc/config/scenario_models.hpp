#pragma once
// What the scenario fixes for the models that the world and the agents share: the target's motion (dle)
// and the field's grid (joint_field). The world draws truth with them and an agent's estimator is built
// with them, so both take them from here.
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/core/types.hpp"
#include "swarmloc/estimators/consensus/joint_field.hpp"

namespace swarmloc::config {

/// The target's model at the world period 1 / run.rate_hz (Atanasov et al. eq. (1)): state dimension 2
/// (static, F and W empty) or 4 (double integrator: F = [I τI; 0 I], W = q [τ³/3 I, τ²/2 I; τ²/2 I, τ I]).
struct TargetModel {
  int dim = 2;
  MatX F;
  MatX W;
};
TargetModel target_model(const Scenario& scenario);

/// The field's grid over the area (world.field_cells_per_side² cells) and the sensing model of its readings.
estimators::consensus::FieldSensor field_sensor(const Scenario& scenario);

}  // namespace swarmloc::config
