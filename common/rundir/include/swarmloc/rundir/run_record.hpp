#pragma once
// Everything a run produces, and the writer of the run directory (docs/design.md §6): scenario.yaml,
// summary.json, metrics.csv, estimates.csv, links.csv, plots/. Shared by `swarmloc run` (DDS) and
// `swarmloc sim` (in-process) so both directories look the same.
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/runtime/envelope.hpp"
#include "swarmloc/runtime/output_file.hpp"
#include "swarmloc/world/bound.hpp"
#include "swarmloc/world/metrics.hpp"
#include "swarmloc/world/optimum.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::rundir {

struct StepMetrics {
  std::int64_t step = 0;
  double time_s = 0.0;
  world::ErrorStats errors;
  /// The static all-draws CRLB at the initial truth, accumulated over step+1 snapshots (kept for older
  /// readers; the run's bound is bound_rmse_m).
  double crlb_rmse_m = 0.0;
  double bound_rmse_m = std::numeric_limits<double>::quiet_NaN();           ///< RunRecord::bound at this step
  double bound_all_data_rmse_m = std::numeric_limits<double>::quiet_NaN();  ///< the same with every draw
  int lost = 0;  ///< agents dead or stalled (unscheduled) at this step: among `missing`
  /// The optimum of the run's data at this step (RunRecord::optimum; NaN off its checkpoints).
  double optimum_rmse_m = std::numeric_limits<double>::quiet_NaN();
};

struct EstimateRow {
  std::int64_t step = 0;
  AgentId agent = 0;
  estimators::Estimate estimate;
  Vec2 truth = Vec2::Zero();
  double truth_z_m = 0.0;  ///< 3-D worlds: the truth's z
  /// The distance from the truth: in space when the estimate has a z (a 3-D world), else in the plane.
  [[nodiscard]] double error_m() const {
    if (estimate.altitude)
      return (join(estimate.mean_m, estimate.altitude->z_m) - join(truth, truth_z_m)).norm();
    return (estimate.mean_m - truth).norm();
  }
};

struct AgentSummary {
  AgentId agent = 0;
  bool anchor = false;
  std::uint32_t steps_run = 0;
  std::uint32_t samples_published = 0;
  std::uint32_t samples_published_in_steps = 0;  ///< not counting start-up announcements
  double cpu_s = 0.0;
  std::array<std::uint32_t, runtime::kRejectReasonCount> rejected_by_reason{};
  std::optional<int> exit_code;  ///< DDS runs: the process's exit status
  /// DDS runs: "ok", or "died" / "stalled" (its last unscheduled loss, docs/robustness.md "Liveness").
  std::string fate = "ok";
  std::int64_t fate_step = -1;  ///< the world step the loss was found at
  std::string fate_reason;      ///< e.g. "process ended: killed by signal 9 (Killed)"
};

struct RunRecord {
  config::Scenario scenario;
  std::string mode;  ///< "sim", "dds-free-run" or "dds-lockstep"
  int agents = 0;
  int anchors = 0;
  double mean_degree = 0.0;
  world::RangeCrlb crlb;  ///< the static all-draws CRLB (summary.json "crlb", kept for older readers)
  world::RunBound
      bound;  ///< the bound of the algorithm's data (summary.json "bound", docs/algorithms.md §1.3.1)
  /// The optimum of the run's own data (summary.json "optimum", docs/algorithms.md §1.3.2).
  world::RunOptimum optimum;
  /// During the run: the data the optimum is solved from (set by compute_run_bounds; released once final).
  std::shared_ptr<world::OptimumAccumulator> optimum_data;
  /// During the run: the last scored step's estimated positions (non-finite where none), the optimum's
  /// second start at the final step (note_scored_estimates).
  std::vector<Vec2> scored_positions;
  /// A 3-D world: their z (Estimate::altitude; non-finite where none), without which a 3-D start is none.
  std::vector<double> scored_z;
  /// A dataset world's steps (World::recorded, set by compute_run_bounds): the truth headings the pose
  /// estimators' 3-DOF NEES is scored against. Null for generated worlds.
  std::shared_ptr<const world::RecordedSteps> recorded;
  std::vector<StepMetrics> metrics;
  std::vector<EstimateRow> estimates;
  std::map<std::pair<AgentId, AgentId>, runtime::LinkCounters> links;  ///< (sender, receiver)
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

/// Sets record.crlb (scenario_crlb) and record.bound (run_bound) from `world` at world step 0, and starts
/// the run's optimum (record.optimum_data).
void compute_run_bounds(RunRecord& record, const world::World& world);
/// Hands world step `step`'s truth (`world`'s, with its z in 3-D) and batches (index = agent id) to the run's
/// optimum; every runtime calls it where it generates them (docs/algorithms.md §1.3.2).
void observe_world_step(RunRecord& record, std::int64_t step, const world::World& world,
                        const std::vector<estimators::MeasurementBatch>& batches);
/// Keeps a scored step's estimates as the optimum's second start; every runtime calls it where it scores.
void note_scored_estimates(RunRecord& record,
                           const std::vector<std::optional<estimators::Estimate>>& estimates);
/// Solves the optimum's pending checkpoints and sets record.optimum and the last metrics row's
/// optimum_rmse_m; `final`: the last observed step too, every metrics row, and the data are released.
void update_run_optimum(RunRecord& record, bool final);
/// Final RMSE / the optimum's RMSE at the final scored step (NaN without one).
double run_efficiency(const RunRecord& record);
/// optimum.csv: each agent's optimum at the final step beside its truth (empty text without one).
std::string optimum_csv(const RunRecord& record);
/// summary.json's "optimum" block: kind, data, anchors, start, step, rmse_m, nees, iterations, converged,
/// interval, points, observe_cpu_s, solve_cpu_s, reference; reason when kind is none.
nlohmann::json optimum_json(const RunRecord& record);
/// Fills metrics.crlb_rmse_m, bound_rmse_m and bound_all_data_rmse_m for metrics.step.
void set_step_bounds(const RunRecord& record, StepMetrics& metrics);
/// summary.json's "bound" block: kind, data, anchors, rmse_m, all_data_rmse_m, ratio (final RMSE / bound),
/// reason (docs/algorithms.md §1.3.1).
nlohmann::json bound_json(const RunRecord& record);

/// RMSE over the whole run: sqrt of the mean over scored steps of the per-step mean squared error (the
/// figure that matters on a trajectory, where the final step is one sample among thousands).
///
/// Pose-state runs on data with a true heading (replay --mrclam, in-process): nees3 is the mean 3-DOF NEES
/// (world::pose_nees, 3 = consistent) over every scored agent-step whose estimate carries a heading and a
/// positive definite covariance; nees3_samples counts them (0: none, and nees3 is NaN).
struct WholeRunError {
  double rmse_m = std::numeric_limits<double>::quiet_NaN();
  std::size_t scored_steps = 0;
  double nees3 = std::numeric_limits<double>::quiet_NaN();
  std::size_t nees3_samples = 0;
};
WholeRunError whole_run_error(const RunRecord& record);

/// Steps at which some agent's estimate was NaN or Inf (ErrorStats::non_finite). Any makes the run's
/// results invalid: `run` and `sim` end with exit 3 and say so (docs/robustness.md, "Non-finite estimates").
struct NonFiniteEstimates {
  std::size_t steps = 0;
  std::int64_t first_step = -1;
  int most_agents = 0;  ///< the most agents broken at one step
};
NonFiniteEstimates non_finite_estimates(const RunRecord& record);

nlohmann::json summary_json(const RunRecord& record);

/// Writes the run directory; creates it if needed. Plots are made with gnuplot when it is installed
/// (a plots/*.gp script is always written so they can be made later). Every write is checked and
/// summary.json comes last, written atomically: its presence marks a complete directory. A failed write
/// throws OutputError naming the file and the OS error.
/// `control.cancel` (Ctrl-C) is polled between files and per agent: once set, writing stops with
/// Cancelled and no summary.json, so the directory reads as incomplete.
void write_run_directory(const std::filesystem::path& directory, const RunRecord& record,
                         const world::WorkControl& control = {});

/// create_directories, throwing OutputError (the directory and the OS error) on failure.
void create_output_directories(const std::filesystem::path& directory);

/// The human-readable result table printed at the end of a run.
std::string result_table(const RunRecord& record);

/// Makes `directory` ready for a run before any work starts, or throws config::ScenarioError (exit 2)
/// naming the path and the cause: it must be creatable and writable, and empty, unless `force` is set
/// and it holds an earlier swarmloc run, which is then cleared.
void prepare_run_directory(const std::filesystem::path& directory, bool force);

/// A fresh run directory name: runs/<scenario name>-<UTC yyyymmdd-hhmmss>-seed<seed>, always directly
/// under runs/ (a name validate() would refuse is made path-safe first).
std::filesystem::path default_run_directory(const config::Scenario& scenario);
/// runs/<name>-<UTC yyyymmdd-hhmmss><suffix>, made unique with -2, -3, … (name made path-safe).
std::filesystem::path fresh_run_directory(const std::string& name, const std::string& suffix = "");

}  // namespace swarmloc::rundir
