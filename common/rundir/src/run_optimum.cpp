// The run's optimum in the run record (docs/algorithms.md §1.3.2): fed by every runtime as it generates
// the batches, solved at checkpoints, written to summary.json, metrics.csv and the result table.
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "swarmloc/rundir/run_record.hpp"

namespace swarmloc::rundir {
namespace {

nlohmann::json finite_or_null(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json();
}

/// What a causal estimate at a step is compared with (docs/algorithms.md §1.3.2).
std::string_view reference_text(world::OptimumKind kind) {
  if (kind == world::OptimumKind::kMapSmoother) {
    return "causal: the MAP of the trajectory given the data up to the step, read at that step (at the "
           "last step the full smoother's final state)";
  }
  return "the ML of every selected draw up to the step";
}

}  // namespace

void observe_world_step(RunRecord& record, std::int64_t step, const world::World& world,
                        const std::vector<estimators::MeasurementBatch>& batches) {
  if (record.optimum_data) record.optimum_data->observe(step, world.truth, batches, world.altitude);
}

void note_scored_estimates(RunRecord& record,
                           const std::vector<std::optional<estimators::Estimate>>& estimates) {
  if (!record.optimum_data) return;
  const Vec2 none = Vec2::Constant(std::numeric_limits<double>::quiet_NaN());
  record.scored_positions.resize(estimates.size());
  for (std::size_t i = 0; i < estimates.size(); ++i) {
    const auto& estimate = estimates[i];
    record.scored_positions[i] = estimate && estimate->valid ? estimate->mean_m : none;
  }
  // A 3-D estimate starts the optimum only with its z (a planar world's estimates have none: left empty).
  const bool spatial = std::any_of(estimates.begin(), estimates.end(),
                                   [](const auto& estimate) { return estimate && estimate->altitude; });
  record.scored_z.clear();
  if (!spatial) return;
  record.scored_z.resize(estimates.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t i = 0; i < estimates.size(); ++i) {
    const auto& estimate = estimates[i];
    if (estimate && estimate->valid && estimate->altitude) record.scored_z[i] = estimate->altitude->z_m;
  }
}

void update_run_optimum(RunRecord& record, bool final) {
  if (!record.optimum_data) return;
  record.optimum_data->solve_pending(
      final, final && !record.scored_positions.empty() ? &record.scored_positions : nullptr,
      final && !record.scored_z.empty() ? &record.scored_z : nullptr);
  record.optimum = record.optimum_data->result();
  if (!final) {
    if (!record.metrics.empty()) {
      const world::OptimumPoint* point = record.optimum.at(record.metrics.back().step);
      if (point != nullptr) record.metrics.back().optimum_rmse_m = point->rmse_m;
    }
    return;
  }
  for (auto& m : record.metrics) {
    const world::OptimumPoint* point = record.optimum.at(m.step);
    m.optimum_rmse_m = point != nullptr ? point->rmse_m : std::numeric_limits<double>::quiet_NaN();
  }
  record.optimum_data.reset();
  record.scored_positions = {};
  record.scored_z = {};
}

std::string optimum_csv(const RunRecord& record) {
  const world::RunOptimum& optimum = record.optimum;
  if (optimum.final_position.empty()) return {};
  std::ostringstream out;
  out.precision(9);
  if (!optimum.final_altitude.empty()) {  // a 3-D world: (x, y, z), the 3×3 covariance's upper triangle
    out << "agent,unknown,x_m,y_m,z_m,cov_xx,cov_xy,cov_xz,cov_yy,cov_yz,cov_zz,truth_x_m,truth_y_m,truth_z_"
           "m,"
           "error_m\n";
    for (std::size_t i = 0; i < optimum.final_position.size(); ++i) {
      const Vec3 x = join(optimum.final_position[i], optimum.final_altitude[i].z_m);
      const Mat3 p = join(optimum.final_covariance[i], optimum.final_altitude[i]);
      const Vec3 truth = join(optimum.final_truth[i], optimum.final_truth_z[i]);
      out << i << ',' << (optimum.final_in_state[i] ? 1 : 0) << ',' << x.x() << ',' << x.y() << ',' << x.z()
          << ',' << p(0, 0) << ',' << p(0, 1) << ',' << p(0, 2) << ',' << p(1, 1) << ',' << p(1, 2) << ','
          << p(2, 2) << ',' << truth.x() << ',' << truth.y() << ',' << truth.z() << ',' << (x - truth).norm()
          << '\n';
    }
    return out.str();
  }
  out << "agent,unknown,x_m,y_m,cov_xx,cov_xy,cov_yy,truth_x_m,truth_y_m,error_m\n";
  for (std::size_t i = 0; i < optimum.final_position.size(); ++i) {
    const Vec2& x = optimum.final_position[i];
    const Mat2& p = optimum.final_covariance[i];
    const Vec2& truth = optimum.final_truth[i];
    out << i << ',' << (optimum.final_in_state[i] ? 1 : 0) << ',' << x.x() << ',' << x.y() << ',' << p(0, 0)
        << ',' << p(0, 1) << ',' << p(1, 1) << ',' << truth.x() << ',' << truth.y() << ','
        << (x - truth).norm() << '\n';
  }
  return out.str();
}

double run_efficiency(const RunRecord& record) {
  const StepMetrics* last = record.final_metrics();
  if (last == nullptr) return std::numeric_limits<double>::quiet_NaN();
  return last->errors.rmse_m / last->optimum_rmse_m;
}

nlohmann::json optimum_json(const RunRecord& record) {
  const world::RunOptimum& optimum = record.optimum;
  nlohmann::json block = {{"kind", std::string(world::to_string(optimum.kind))}};
  if (optimum.kind == world::OptimumKind::kNone) {
    block["reason"] = optimum.reason;
    return block;
  }
  block["data"] = std::string(world::to_string(optimum.draws));
  block["anchors"] = std::string(world::to_string(optimum.anchors));
  block["reference"] = std::string(reference_text(optimum.kind));
  const StepMetrics* last = record.final_metrics();
  const world::OptimumPoint* point = last != nullptr ? optimum.at(last->step) : nullptr;
  // The truth, or the run's final estimates where the data fit them at least as well (docs/algorithms.md
  // §1.3.2).
  block["start"] = point != nullptr && point->from_estimates ? "estimates" : "truth";
  block["step"] = point != nullptr ? nlohmann::json(point->step) : nlohmann::json();
  block["rmse_m"] = point != nullptr ? finite_or_null(point->rmse_m) : nlohmann::json();
  block["nees"] = point != nullptr ? finite_or_null(point->nees) : nlohmann::json();
  block["iterations"] = point != nullptr ? point->iterations : 0;
  block["converged"] = point != nullptr && point->converged;
  // A degenerate ML: its information is singular at the solution, so it has no covariance (nees null).
  if (point != nullptr && point->singular_at_solution) block["singular_at_solution"] = true;
  if (point != nullptr && !point->localizable) block["localizable"] = false;  // rmse_m null
  block["interval"] = optimum.interval;
  block["points"] = optimum.points.size();
  block["observe_cpu_s"] = optimum.observe_cpu_s;
  block["solve_cpu_s"] = optimum.solve_cpu_s;
  return block;
}

}  // namespace swarmloc::rundir
