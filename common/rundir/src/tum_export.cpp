#include "swarmloc/rundir/tum_export.hpp"

#include <cmath>
#include <iomanip>
#include <map>
#include <sstream>
#include <string>

#include "swarmloc/runtime/output_file.hpp"

namespace swarmloc::rundir {
namespace {

void write_line(std::ostringstream& out, double time_s, const Vec2& position, double z_m) {
  out << time_s << ' ' << position.x() << ' ' << position.y() << ' ' << z_m << " 0 0 0 1\n";
}

}  // namespace

int write_tum_trajectories(const std::filesystem::path& directory, const RunRecord& record,
                           const world::WorkControl& control) {
  if (record.estimates.empty()) return 0;
  std::map<std::int64_t, double> step_time;
  for (const auto& m : record.metrics) step_time[m.step] = m.time_s;
  const double rate_hz = record.scenario.run.rate_hz;
  auto time_of = [&](std::int64_t step) {
    const auto it = step_time.find(step);
    if (it != step_time.end()) return it->second;
    return rate_hz > 0.0 ? static_cast<double>(step) / rate_hz : static_cast<double>(step);
  };
  // Per agent, ordered by step; a re-scored step keeps its newest row, so timestamps strictly increase.
  std::map<AgentId, std::map<std::int64_t, const EstimateRow*>> rows;
  for (const auto& row : record.estimates) rows[row.agent][row.step] = &row;

  const auto out_dir = directory / "trajectories";
  create_output_directories(out_dir);
  int written = 0;
  for (const auto& [agent, by_step] : rows) {
    control.throw_if_cancelled();
    const auto stem = out_dir / ("agent_" + std::to_string(agent));
    std::ostringstream estimate;
    std::ostringstream truth;
    estimate << std::setprecision(12);
    truth << std::setprecision(12);
    for (const auto& [step, row] : by_step) {
      const double t = time_of(step);
      if (!std::isfinite(t)) continue;
      const auto& altitude = row->estimate.altitude;
      if (row->estimate.mean_m.allFinite())
        write_line(estimate, t, row->estimate.mean_m, altitude ? altitude->z_m : 0.0);
      if (row->truth.allFinite()) write_line(truth, t, row->truth, row->truth_z_m);
    }
    runtime::write_text_file(stem.string() + ".tum", estimate.str());
    runtime::write_text_file(stem.string() + "_truth.tum", truth.str());
    ++written;
  }
  return written;
}

}  // namespace swarmloc::rundir
