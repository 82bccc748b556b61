#include "murp_replay.hpp"

#include <chrono>
#include <cstdio>
#include <exception>

#include "murp_dds.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/rundir/murp_run.hpp"
#include "swarmloc/rundir/run_record.hpp"
#include "swarmloc/runtime/output_file.hpp"
#include "swarmloc/runtime/range_calibration_file.hpp"
#include "swarmloc/sim/murp_team_run.hpp"
#include "swarmloc/world/murp.hpp"

namespace swarmloc::orchestrator {
namespace {

namespace uwb = estimators::uwb;

struct ChosenCalibration {
  uwb::RangeCalibration calibration;
  std::string source;  ///< for the summary and the table
};

ChosenCalibration choose_calibration(const MurpReplayOptions& options) {
  ChosenCalibration chosen;
  if (options.bias_path.empty()) {
    chosen.calibration = runtime::builtin_murp_calibration();
    chosen.source = "built-in (scenarios/murp-range-bias.json)";
  } else {
    chosen.calibration = runtime::read_range_calibration(options.bias_path);
    chosen.source = options.bias_path;
  }
  if (!chosen.calibration.fitted_on.empty()) {
    chosen.source += ", fitted on trials";
    for (const auto& trial : chosen.calibration.fitted_on) chosen.source += " " + trial;
  }
  if (options.no_bias) {
    chosen.calibration = uwb::without_bias(chosen.calibration);
    chosen.source = "none";
  }
  return chosen;
}

sim::MurpTeamOptions team_options(const uwb::RangeCalibration& calibration, const world::MurpTrial& trial,
                                  bool cooperate) {
  sim::MurpTeamOptions options;
  options.cooperate = cooperate;
  for (const auto& pair : trial.pairs) {
    options.models[{pair.base, pair.target}] = uwb::range_model(calibration, pair.base, pair.target);
  }
  return options;
}

int skipped_windows(const world::MurpTrial& trial) {
  int skipped = 0;
  for (const auto& pair : trial.pairs) skipped += pair.skipped_windows;
  return skipped;
}

void print_table(const rundir::MurpRunInfo& info, const world::MurpScore& score, std::size_t windows) {
  std::printf("\nMURP trial %s (%s): %zu windows, range bias: %s, cooperation %s\n", info.trial.c_str(),
              info.mode.c_str(), windows, info.bias.c_str(), info.cooperation ? "on" : "off");
  std::printf("  %-10s %8s %10s %10s %12s %14s %10s\n", "vehicle", "windows", "pos MAE", "pos RMSE",
              "heading MAE", "error/distance", "distance");
  const auto line = [](const std::string& name, const world::RelativeErrorStats& s) {
    std::printf("  %-10s %8lld %8.3f m %8.3f m %10.2f deg %13.1f %% %8.2f m\n", name.c_str(),
                static_cast<long long>(s.windows), s.position_mae_m(), s.position_rmse_m(),
                s.heading_mae_deg(), 100.0 * s.range_normalized_mae(), s.mean_distance_m());
  };
  for (const auto& [pair, stats] : score.per_pair) {
    line(std::to_string(pair.first) + " sees " + std::to_string(pair.second), stats);
  }
  line("pooled", score.pooled);
  if (score.missing_estimates > 0) {
    std::printf("  %lld pair-windows had no estimate (a vehicle had not localized that peer)\n",
                static_cast<long long>(score.missing_estimates));
  }
  std::printf("  truth: the window poses (docs/real-data.md: MURP)\n");
}

}  // namespace

int run_murp_replay(const MurpReplayOptions& options) {
  world::MurpTrial trial;
  ChosenCalibration chosen;
  std::filesystem::path out_dir = options.out_dir;
  try {
    trial = world::load_murp_trial(options.trial_dir);
    chosen = choose_calibration(options);
    for (const auto& pair : trial.pairs) uwb::range_model(chosen.calibration, pair.base, pair.target);
    if (out_dir.empty()) out_dir = rundir::fresh_run_directory("murp-" + trial.name);
    rundir::prepare_run_directory(out_dir, options.force);
  } catch (const std::out_of_range&) {
    std::fprintf(stderr, "error: the range calibration has no entry for one of the trial's vehicles\n");
    return 2;
  } catch (const config::ScenarioError& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 2;
  }
  const auto windows = world::murp_team_windows(trial);
  rundir::MurpRunInfo info{trial.name,
                           trial.directory,
                           options.in_process ? "sim" : "dds-lockstep",
                           chosen.source,
                           options.cooperate,
                           skipped_windows(trial),
                           nlohmann::json::object()};
  try {
    rundir::create_output_directories(out_dir);
    const auto model_path = out_dir / "range_model.json";
    runtime::write_text_file(
        model_path,
        runtime::range_calibration_json(chosen.calibration, "range model of this run: " + chosen.source));
    std::vector<world::RelativeEstimateRow> rows;
    const auto started = std::chrono::steady_clock::now();
    if (options.in_process) {
      rows = sim::run_murp_team(windows, team_options(chosen.calibration, trial, options.cooperate));
    } else {
      MurpDdsOptions dds{options.agent_binary, out_dir,           model_path,
                         options.cooperate,    options.domain_id, options.progress};
      dds.ros2 = options.ros2;
      dds.ros2_subscribers = options.ros2_subscribers;
      auto run = run_murp_over_dds(windows, dds);
      if (run.bad_input) {
        std::fprintf(stderr, "error: %s\n", run.failure.c_str());
        return 2;
      }
      rows = std::move(run.rows);
      info.extra = run.counters;
      if (run.failed) {
        std::fprintf(stderr, "error: %s\n", run.failure.c_str());
        info.extra["failure"] = run.failure;
        const auto score = world::score_murp(windows, rows);
        rundir::write_murp_run_directory(out_dir, info, windows, rows, score);
        return 1;
      }
    }
    info.extra["wall_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    const auto score = world::score_murp(windows, rows);
    rundir::write_murp_run_directory(out_dir, info, windows, rows, score);
    print_table(info, score, windows.size());
    std::printf("  run directory: %s\n", out_dir.string().c_str());
  } catch (const runtime::OutputError& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 1;
  }
  return 0;
}

}  // namespace swarmloc::orchestrator
