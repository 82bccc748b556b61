#pragma once
// Everything a run produces, and the writer of the run directory (DESIGN.md §6): scenario.yaml,
// summary.json, metrics.csv, estimates.csv, links.csv, plots/. Shared by `swarmloc run` (DDS) and
// `swarmloc sim` (in-process) so both directories look the same.
#include <filesystem>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/sim/envelope.hpp"
#include "swarmloc/sim/metrics.hpp"

namespace swarmloc::sim {

struct StepMetrics {
  std::int64_t step = 0;
  double time_s = 0.0;
  ErrorStats errors;
  double crlb_rmse_m = 0.0;  ///< accumulated over step+1 snapshots
};

struct EstimateRow {
  std::int64_t step = 0;
  AgentId agent = 0;
  estimators::Estimate estimate;
  Vec2 truth = Vec2::Zero();
};

struct AgentSummary {
  AgentId agent = 0;
  bool anchor = false;
  std::uint32_t steps_run = 0;
  std::uint32_t samples_published = 0;
  std::uint32_t samples_published_in_steps = 0;  ///< not counting start-up announcements
  double cpu_s = 0.0;
  std::array<std::uint32_t, kRejectReasonCount> rejected_by_reason{};
  std::optional<int> exit_code;  ///< DDS runs: the process's exit status
};

struct RunRecord {
  config::Scenario scenario;
  std::string mode;  ///< "sim", "dds-free-run" or "dds-lockstep"
  int agents = 0;
  int anchors = 0;
  double mean_degree = 0.0;
  RangeCrlb crlb;
  std::vector<StepMetrics> metrics;
  std::vector<EstimateRow> estimates;
  std::map<std::pair<AgentId, AgentId>, LinkCounters> links;  ///< (sender, receiver)
  std::vector<AgentSummary> agent_summaries;
  int processes = 0;
  double wall_s = 0.0;
  /// DDS runs: wall time from START to STOP, over which agents report their CPU (0: steps / rate).
  double world_phase_s = 0.0;
  bool interrupted = false;
  nlohmann::json extra = nlohmann::json::object();  ///< runtime-specific fields

  [[nodiscard]] const StepMetrics* final_metrics() const {
    return metrics.empty() ? nullptr : &metrics.back();
  }
};

struct LinkTotals {
  std::uint64_t sent = 0, arrived = 0, delivered = 0, dropped_injected = 0, rejected = 0;
  std::uint64_t delivered_in_steps = 0;
};
LinkTotals link_totals(const RunRecord& record);

/// RMSE over the whole run: sqrt of the mean over scored steps of the per-step mean squared error (the
/// figure that matters on a trajectory, where the final step is one sample among thousands).
struct WholeRunError {
  double rmse_m = std::numeric_limits<double>::quiet_NaN();
  std::size_t scored_steps = 0;
};
WholeRunError whole_run_error(const RunRecord& record);

nlohmann::json summary_json(const RunRecord& record);

/// Writes the run directory; creates it if needed. Plots are made with gnuplot when it is installed
/// (a plots/*.gp script is always written so they can be made later).
void write_run_directory(const std::filesystem::path& directory, const RunRecord& record);

/// The human-readable result table printed at the end of a run.
std::string result_table(const RunRecord& record);

/// A fresh run directory name: runs/<scenario name>-<UTC yyyymmdd-hhmmss>-seed<seed>.
std::filesystem::path default_run_directory(const config::Scenario& scenario);

}  // namespace swarmloc::sim
