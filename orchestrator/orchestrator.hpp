#pragma once
// `swarmloc run`: owns the world, launches the agent processes, publishes measurements every world
// step, collects and scores estimates, and writes the run directory.
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/core/types.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::orchestrator {

struct RunOptions {
  std::string scenario_path;
  std::vector<std::string> overrides;
  std::filesystem::path out_dir;        ///< empty: runs/<name>-<stamp>-seed<seed>
  bool force = false;                   ///< --force: a non-empty out_dir holding an earlier run is cleared
  std::string agent_binary;             ///< the swarmloc executable used to start agents
  bool launch_agents = true;            ///< false: wait for agents started elsewhere
  std::vector<AgentId> hostile_agents;  ///< agents started with --hostile
  bool progress = true;
  /// Which Monte Carlo trial's world to run (`--trial`; as `sim --trial`).
  std::uint64_t trial = 0;
  int view_port = -1;         ///< >= 0: live view on 127.0.0.1:view_port (0: any free port); -1: none
  double view_hold_s = 10.0;  ///< after the run, the live view keeps serving this long (inf: until Ctrl-C)
  /// --record: recording.slrec (truth + every published batch) and recording/agent_<id>.slrec (each
  /// agent's received inter-agent samples) in the run directory.
  bool record = false;
  /// Replay: the world's truth and batches come from here (World::recorded), not the generator.
  std::shared_ptr<const world::RecordedSteps> recorded;
  nlohmann::json summary_extra = nlohmann::json::object();  ///< added to summary.json (replay provenance)
};

/// Returns the process exit code (0 ok, 2 bad input, 1 runtime failure or interrupted).
int run_orchestrator(const RunOptions& options);
/// The same for a scenario already loaded (options.scenario_path is ignored).
int run_orchestrator(config::Scenario scenario, const RunOptions& options);

struct SimCommandOptions {
  std::string scenario_path;
  std::vector<std::string> overrides;
  std::filesystem::path out_dir;
  bool force = false;  ///< --force: a non-empty out_dir holding an earlier run is cleared
  bool progress = true;
  /// A single run: which Monte Carlo trial it is (`--trial`; its row in trials.csv).
  std::uint64_t trial = 0;
  int trials = 1;      ///< > 1: Monte Carlo over every core
  int threads = 0;     ///< trials (0 = every core), or one run's rounds (SimOptions::round_threads; 0 =
                       ///< auto_round_threads)
  int view_port = -1;  ///< >= 0: paced playback in the live view on 127.0.0.1:view_port (0: any port)
  double view_hold_s = 10.0;            ///< after the playback, keep serving this long (inf: until Ctrl-C)
  std::vector<AgentId> hostile_agents;  ///< publish garbage, as `run --hostile` (single runs only)
  /// --record: recording.slrec and recording/samples.slrec in the run directory (single runs only).
  bool record = false;
  std::shared_ptr<const world::RecordedSteps> recorded;     ///< replay (see RunOptions::recorded)
  nlohmann::json summary_extra = nlohmann::json::object();  ///< added to summary.json
};

/// `swarmloc sim`: the in-process runner.
int run_sim_command(const SimCommandOptions& options);
/// The same for a scenario already loaded (options.scenario_path is ignored).
int run_sim_command(config::Scenario scenario, const SimCommandOptions& options);

}  // namespace swarmloc::orchestrator
