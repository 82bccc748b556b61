#include "swarmloc/estimators/consensus/joint_field.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "consensus/information_consensus.hpp"

namespace swarmloc::estimators::consensus {

Vec2 FieldGrid::centre(int cell) const {
  const int row = cell / columns;
  const int col = cell % columns;
  return origin_m + cell_m * Vec2(col + 0.5, row + 0.5);
}

int FieldGrid::cell_of(const Vec2& position_m) const {
  const Vec2 local = (position_m - origin_m) / cell_m;
  const int col = std::clamp(static_cast<int>(std::floor(local.x())), 0, columns - 1);
  const int row = std::clamp(static_cast<int>(std::floor(local.y())), 0, rows - 1);
  return row * columns + col;
}

void validate(const FieldSensor& sensor) {
  auto fail = [](const std::string& what) { throw std::invalid_argument("field." + what); };
  if (sensor.grid.columns < 1 || sensor.grid.rows < 1) fail("grid: needs at least one column and one row");
  if (!(sensor.grid.cell_m > 0.0) || !std::isfinite(sensor.grid.cell_m)) fail("cell_m: must be > 0");
  if (!sensor.grid.origin_m.allFinite()) fail("origin_m: must be finite");
  if (!(sensor.radius_m > 0.0) || !std::isfinite(sensor.radius_m)) fail("radius_m: must be > 0");
}

VecX field_observation_row(const FieldSensor& sensor, const Vec2& position_m) {
  const FieldGrid& grid = sensor.grid;
  VecX h = VecX::Zero(grid.cells());
  if (sensor.sensing == FieldSensing::kCellBased) {
    h(grid.cell_of(position_m)) = 1.0;
    return h;
  }
  for (int k = 0; k < grid.cells(); ++k)
    h(k) = std::max(0.0, 1.0 - (position_m - grid.centre(k)).norm() / sensor.radius_m);
  return h;
}

void validate(const JointFieldParams& params) {
  validate(params.sensor);
  if (!params.reference_position_m.allFinite())
    throw std::invalid_argument("joint_field.reference_position_m: must be finite");
  if (!(params.delta > 0.0) || !std::isfinite(params.delta))
    throw std::invalid_argument("joint_field.delta: must be > 0 (it keeps (Ω + sδI) invertible)");
  if (params.warmup_steps < 0) throw std::invalid_argument("joint_field.warmup_steps: must be >= 0");
}

JointLocalizationField::JointLocalizationField(const AgentSetup& setup, const JointFieldParams& params)
    : setup_(setup), params_(params), jacobi_(setup) {
  validate(params);
  const Eigen::Index d = params.sensor.grid.cells();
  omega_ = VecX::Zero(d);  // ω_{i,0} = 0, Ω_{i,0} = 0 (static field, docs/algorithms.md §4.2)
  Omega_ = MatX::Zero(d, d);
  y_ = VecX::Zero(d);
}

Vec2 JointLocalizationField::sensing_position() const {
  return params_.reference_position_m + (params_.localize ? jacobi_.mean() : setup_.initial_guess_m);
}

Outbox JointLocalizationField::published(const Outbox& localization) const {
  Outbox outbox = localization;
  if (!outbox.state) outbox.state = StateMessage{};
  outbox.state->degree = static_cast<std::uint16_t>(degrees_.own);  // the degree our κ use
  if (!params_.localize) {
    outbox.state->mean_m = setup_.initial_guess_m;
    outbox.state->covariance = Mat2::Zero();
  }
  outbox.information = InformationMessage{params_.target, omega_, Omega_};
  return outbox;
}

Outbox JointLocalizationField::initial_outbox() const { return published(jacobi_.initial_outbox()); }

StepOutput JointLocalizationField::step(const StepInput& input) {
  StepOutput out;
  const VecX h = field_observation_row(params_.sensor, sensing_position());  // Ĥ_{i,t} = h(x̂_i(t))
  auto [omega, Omega] = detail::combine_priors(omega_, Omega_, params_.target, input, params_.weights,
                                               degrees_, out.diagnostics);
  if (input.measurements != nullptr && steps_taken_ >= params_.warmup_steps) {
    for (const TargetObservation& z : input.measurements->targets) {
      const double variance = z.covariance(0, 0);
      if (z.target != params_.target || z.kind != kFieldReading || !std::isfinite(z.value(0)) ||
          !(variance > 0.0) || !std::isfinite(variance))
        continue;
      omega += h * (z.value(0) / variance);             // Ĥᵀ V⁻¹ z
      Omega.noalias() += h * h.transpose() / variance;  // Ĥᵀ V⁻¹ Ĥ, exactly symmetric
      out.diagnostics.updated = true;
    }
  }
  omega_ = std::move(omega);
  Omega_ = std::move(Omega);
  ++steps_taken_;
  // eq. (10): ŷ = (Ω + (t+1) δ I)⁻¹ ω; the regularization keeps the system positive definite.
  const double regularization = static_cast<double>(steps_taken_) * params_.delta;
  const Eigen::LLT<MatX> llt(Omega_ + regularization * MatX::Identity(Omega_.rows(), Omega_.cols()));
  if (llt.info() == Eigen::Success) y_ = llt.solve(omega_);

  StepOutput localization;
  if (params_.localize) {
    localization = jacobi_.step(input);
  } else {
    localization.outbox = jacobi_.initial_outbox();
  }
  out.outbox = published(localization.outbox);
  return out;
}

Estimate JointLocalizationField::estimate() const {
  Estimate estimate =
      params_.localize ? jacobi_.estimate() : detail::known_position_estimate(setup_.initial_guess_m);
  if (steps_taken_ > 0) estimate.field = y_;
  return estimate;
}

}  // namespace swarmloc::estimators::consensus
