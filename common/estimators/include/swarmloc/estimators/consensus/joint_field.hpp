#pragma once
// Joint localization and field estimation (Atanasov et al. eq. (10), docs/algorithms.md §4.4, Fig. 5): each
// sensor localizes itself by distributed Jacobi (§4.3) while it estimates a static scalar field on a grid by
// the DLE (§4.2), using the observation model evaluated at its current position estimate.
#include <cstdint>
#include <optional>
#include <string_view>

#include "swarmloc/estimators/consensus/jacobi.hpp"
#include "swarmloc/estimators/consensus/metropolis.hpp"
#include "swarmloc/estimators/estimator.hpp"

namespace swarmloc::estimators::consensus {

/// A static scalar field on `columns` × `rows` square cells; cell k = row·columns + col has its centre at
/// origin + cell_m·(col + ½, row + ½). The field is y ∈ R^cells, one value per cell.
struct FieldGrid {
  Vec2 origin_m = Vec2::Zero();
  double cell_m = 10.0;
  int columns = 10;
  int rows = 10;

  [[nodiscard]] int cells() const { return columns * rows; }
  [[nodiscard]] Vec2 centre(int cell) const;
  /// The cell that contains `position_m` (clamped to the grid); a point on a boundary belongs to the cell on
  /// its upper/right side.
  [[nodiscard]] int cell_of(const Vec2& position_m) const;
};

enum class FieldSensing {
  /// h_k(x) = max(0, 1 − ‖x − c_k‖ / r_s): continuous in the sensor position x (docs/algorithms.md §4.6
  /// default).
  kContinuous,
  /// h = e_cell(x): the sensor reads the cell that contains it. The model depends only on which cell the
  /// sensor is in, so it jumps at cell boundaries (Atanasov et al. Fig. 5, rightmost plot). (Tents around the
  /// containing
  /// cell's centre would jump too, but with r_s = 1.5 cells their rows are nearly dependent — a checkerboard
  /// field is almost invisible — and the field is then poorly observed even with true positions.)
  kCellBased,
};

struct FieldSensor {
  FieldGrid grid;
  FieldSensing sensing = FieldSensing::kContinuous;
  double radius_m = 15.0;  ///< r_s (continuous model)
};

/// Row h(x) of the observation z = h(x)ᵀ y + v of a sensor at `position_m` (Atanasov et al. eq. (2) with d_z
/// = 1).
VecX field_observation_row(const FieldSensor& sensor, const Vec2& position_m);

/// Throws std::invalid_argument naming the offending field.
void validate(const FieldSensor& sensor);

/// Observations of the field arrive as MeasurementBatch::targets with kind kFieldReading: value(0) = z,
/// covariance(0, 0) = V (scalar); the other components are ignored.
inline constexpr std::uint8_t kFieldReading = 2;

struct JointFieldParams {
  FieldSensor sensor;
  std::int32_t target = 0;  ///< only readings and InformationMessages of this target are used
  /// Absolute position of the reference node: Atanasov et al. localizes in node 1's frame, the field lives in
  /// the world frame, so sensor i is at reference + x̂_i.
  Vec2 reference_position_m = Vec2::Zero();
  double delta = 1e-3;  ///< δ of eq. (10) (unstated in Atanasov et al.; docs/algorithms.md §4.4 default)
  /// Field readings of the sensor's first `warmup_steps` steps are left out (not in Atanasov et al., whose
  /// value is 0). Eq. (10) never revises a reading's model row Ĥ = h(x̂), so readings taken while x̂ is still
  /// in its transient bias ŷ for the rest of the run, and how much depends on the timing of early steps.
  int warmup_steps = 0;
  /// false: the sensor does not localize and uses AgentSetup::initial_guess_m as its (known) position —
  /// the "DLE with true sensor positions" baseline of §4.6.
  bool localize = true;
  MetropolisRule weights = MetropolisRule::kPlusOne;
};

/// Throws std::invalid_argument naming the offending field.
void validate(const JointFieldParams& params);

/// One sensor of Atanasov et al.'s joint procedure. Each step():
///   1. Ĥ_{i,t} = h(reference + x̂_i(t)) with the position estimate before this step's Jacobi update (eq.
///   (10));
///   2. (ω, Ω) ← Σ_{j∈N_i∪{i}} κ_ij (ω_j, Ω_j) + Σ Ĥᵀ V⁻¹ (z, Ĥ) (static field: no prediction), κ Metropolis
///      weights renormalized over the priors received (§4.5); readings from step warmup_steps on;
///   3. x̂_i ← the Jacobi update of eq. (9) (skipped when localize = false);
///   4. ŷ_i = (Ω + s δ I)⁻¹ ω, s = the number of steps taken ([C-4]: identity of the field's dimension).
/// Publishes the Jacobi STATE (with the degree the weights use) and INFO {target, ω, Ω}.
class JointLocalizationField final : public Estimator {
 public:
  JointLocalizationField(const AgentSetup& setup, const JointFieldParams& params);

  [[nodiscard]] std::string_view name() const override { return "joint_field"; }
  [[nodiscard]] Outbox initial_outbox() const override;
  StepOutput step(const StepInput& input) override;
  /// The position estimate in the reference node's frame (as JacobiLocalization's), with the field estimate
  /// ŷ_i once a step has run.
  [[nodiscard]] Estimate estimate() const override;

  /// ŷ_i after the last step (zero before the first).
  [[nodiscard]] const VecX& field_estimate() const { return y_; }
  /// The sensor position the field model uses: reference + x̂_i (or the known position).
  [[nodiscard]] Vec2 sensing_position() const;

 private:
  [[nodiscard]] Outbox published(const Outbox& localization) const;

  AgentSetup setup_;
  JointFieldParams params_;
  JacobiLocalization jacobi_;
  VecX omega_;
  MatX Omega_;
  VecX y_;
  std::int64_t steps_taken_ = 0;
  ConsensusDegrees degrees_;
};

}  // namespace swarmloc::estimators::consensus
