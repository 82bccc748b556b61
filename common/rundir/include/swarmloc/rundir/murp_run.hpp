#pragma once
// The run directory of a MURP replay (`swarmloc replay --murp`, docs/real-data.md, "MURP"): summary.json with
// the pooled and per-pair relative errors, relative.csv (every reported estimate beside its truth),
// trajectories/ (TUM files of each vehicle's view of each peer, and the truth) and plots/ (error against time
// and against distance).
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "swarmloc/world/murp_team.hpp"

namespace swarmloc::rundir {

struct MurpRunInfo {
  std::string trial;  ///< "13"
  std::filesystem::path trial_dir;
  std::string mode;         ///< "sim" or "dds-lockstep"
  std::string bias;         ///< where the range bias came from, or "none"
  bool cooperation = true;  ///< loop closure among the vehicles
  int skipped_windows = 0;  ///< file rows the loader dropped (too few ranges, no pose)
  nlohmann::json extra = nlohmann::json::object();  ///< runtime-specific fields (DDS counters)
};

/// summary.json's object (also what the result table prints from).
nlohmann::json murp_summary_json(const MurpRunInfo& info, const world::MurpScore& score);

/// Writes summary.json (last, so that its presence vouches for the rest), relative.csv, trajectories/ and
/// plots/ (PNGs when gnuplot is installed). Throws runtime::OutputError for a write that did not make it.
void write_murp_run_directory(const std::filesystem::path& directory, const MurpRunInfo& info,
                              const std::vector<world::MurpTeamWindow>& windows,
                              const std::vector<world::RelativeEstimateRow>& rows,
                              const world::MurpScore& score);

}  // namespace swarmloc::rundir
