#pragma once
// What the parts of `swarmloc-research campaign` share: campaign_spec.cpp (the spec), campaign_cells.cpp
// (one run), campaign_report.cpp (tables, CSV, plot) and campaign.cpp (the command).
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "campaign.hpp"

namespace swarmloc::research::campaign_detail {

using Clock = std::chrono::steady_clock;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

inline double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// ---------------- the spec (campaign_spec.cpp) ----------------

/// The modes of a --mode flag (sim, dds or both); throws config::ScenarioError otherwise.
std::vector<std::string> parse_mode_flag(const std::string& mode);

/// Overrides of one cell, in the order they apply (later wins).
std::vector<std::string> cell_overrides(const CampaignSpec& spec, std::size_t algorithm, std::size_t variant,
                                        std::size_t value, std::uint64_t seed);

std::string cell_name(const CampaignSpec& spec, std::size_t algorithm, std::size_t variant,
                      std::size_t value);

/// A label as a directory name.
std::string path_safe(const std::string& text);

// ---------------- one run (campaign_cells.cpp) ----------------

struct RunResult {
  std::string mode;
  std::size_t algorithm = 0, variant = 0, value = 0;
  std::uint64_t seed = 0;
  bool ok = false;
  std::string error;
  double final_rmse_m = kNaN;
  double crlb_rmse_m = kNaN;  ///< static all-draws CRLB at the last step (summary.json "crlb", older readers)
  double bound_rmse_m = kNaN;  ///< the run's bound at the last step (summary.json "bound"; NaN: none)
  std::string bound_kind;      ///< crlb_static_accumulated, pcrb or none (docs/algorithms.md §1.3.1)
  std::int64_t converge_step = -1;
  double converge_s = kNaN;
  bool still_falling = false;
  std::uint64_t sent = 0, delivered = 0, dropped_injected = 0;
  double wall_s = 0.0;
  std::filesystem::path run_dir;
};

/// A simulator cell: in-process, writing a slim run directory (scenario.yaml, summary.json,
/// metrics.csv; no per-agent estimates or plots, which would dominate the campaign's cost).
void run_sim_cell(const CampaignSpec& spec, RunResult& result);

/// A DDS cell: the same code path as `swarmloc run` (orchestrator in this process, one agent process
/// per agent), then its run directory is read back. Sets `interrupted` if the run was.
void run_dds_cell(const CampaignSpec& spec, RunResult& result, const std::string& agent_binary,
                  bool& interrupted);

// ---------------- aggregation and output (campaign_report.cpp) ----------------

struct CellStats {
  int runs = 0;  ///< successful seeds
  int failed = 0;
  double rmse_mean = kNaN, rmse_std = kNaN, bound_mean = kNaN, converge_s_mean = kNaN;
  double delivered_fraction = kNaN;
  double ratio = kNaN;  ///< rmse_mean / the reference (first swept value) cell's rmse_mean
  /// Median over seeds of (this seed's RMSE / the same seed's reference RMSE): one badly placed world
  /// (a seed where the algorithm is poor even without loss) cannot dominate it.
  double seed_ratio_median = kNaN;
  std::vector<std::uint64_t> still_falling_seeds;  ///< runs whose RMSE was still falling at the horizon
};

using CellKey =
    std::tuple<std::string, std::size_t, std::size_t, std::size_t>;  // mode, algorithm, variant, value

std::map<CellKey, CellStats> aggregate(const std::vector<RunResult>& runs);

struct ModeRun {
  std::string mode;
  std::size_t seeds = 0;
  double wall_s = 0.0;
  bool interrupted = false;
};

/// snprintf of one number; "n/a" when it is not finite.
std::string fmt(const char* format, double value);

/// campaign.md.
std::string campaign_markdown(const CampaignSpec& spec, const std::vector<ModeRun>& modes,
                              const std::map<CellKey, CellStats>& cells);

/// campaign.csv: a row per run.
void write_csv(const std::filesystem::path& path, const CampaignSpec& spec,
               const std::vector<RunResult>& runs);

/// campaign.gp + campaign_plot.dat (always) and campaign.png (when gnuplot is installed): per mode one
/// row of two panels, final RMSE ÷ reference and time to converge vs the swept value; a line per
/// algorithm × variant (colour = algorithm, dash = variant).
void write_plot(const std::filesystem::path& directory, const CampaignSpec& spec,
                const std::vector<ModeRun>& modes, const std::map<CellKey, CellStats>& cells);

}  // namespace swarmloc::research::campaign_detail
