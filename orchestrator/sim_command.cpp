// `swarmloc sim`: the in-process runner behind the same run directory and result table as `run`.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstddef>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <mutex>
#include <thread>

#include "console.hpp"
#include "live_view.hpp"
#include "orchestrator.hpp"
#include "preflight.hpp"
#include "swarmloc/rundir/recording.hpp"
#include "swarmloc/sim/centralized_runner.hpp"
#include "swarmloc/sim/simulator.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::orchestrator {

namespace {

/// Completed, but some estimate was NaN or Inf: the figures are not valid (README, exit codes).
constexpr int kExitInvalidResults = 3;

/// Says on stderr what a phase that reports nothing itself is doing once it has lasted two seconds
/// (writing 10^5 agents' trajectories and plots takes tens of seconds), then every five.
class SlowPhaseNotice {
 public:
  SlowPhaseNotice(bool enabled, std::string what) {
    if (!enabled) return;
    thread_ = std::thread([this, what = std::move(what)] {
      const auto started = Clock::now();
      Progress progress(true);
      std::unique_lock<std::mutex> lock(mutex_);
      auto wait = std::chrono::seconds(2);
      while (!cv_.wait_for(lock, wait, [this] { return done_; })) {
        progress.update("[" + std::to_string(static_cast<int>(seconds_since(started))) + "s] " + what + " …",
                        true);
        wait = std::chrono::seconds(5);
      }
    });
  }
  ~SlowPhaseNotice() {
    if (!thread_.joinable()) return;
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      done_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  SlowPhaseNotice(const SlowPhaseNotice&) = delete;
  SlowPhaseNotice& operator=(const SlowPhaseNotice&) = delete;

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  bool done_ = false;
  std::thread thread_;
};

/// What the phases of `swarmloc sim` share.
struct SimCommand {
  const config::Scenario& scenario;
  const SimCommandOptions& options;
  const std::filesystem::path& run_dir;
  Progress& progress;
  Clock::time_point started;
  const world::WorkControl& control;
  const char*& cancelled_when;  ///< what an interrupt (world::Cancelled) leaves behind, for its message
};

/// Option combinations `sim` refuses: 2 (told on stderr), else 0. (--view with --trials is checked
/// later, once the run directory is named.)
int check_options(const config::Scenario& scenario, const SimCommandOptions& options) {
  try {
    check_hostile_ids(options.hostile_agents, scenario);
  } catch (const config::ScenarioError& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 2;
  }
  if (!options.hostile_agents.empty() && options.trials > 1) {
    std::fprintf(stderr, "error: --hostile is for single runs; it cannot be combined with --trials\n");
    return 2;
  }
  if (options.trial > 0 && options.trials > 1) {
    std::fprintf(stderr, "error: --trial runs one trial; it cannot be combined with --trials\n");
    return 2;
  }
  if (options.record && scenario.world.dimensions == 3) {
    std::fprintf(stderr, "error: --record keeps planar worlds only; this one has world.dimensions: 3\n");
    return 2;
  }
  if ((options.record || options.recorded) && options.trials > 1) {
    std::fprintf(stderr,
                 "error: --record and replay are single runs; they cannot be combined with --trials\n");
    return 2;
  }
  return 0;
}

/// --view: the live view, showing the world while the in-process run computes.
std::unique_ptr<LiveView> start_view(const config::Scenario& scenario, const world::World& world,
                                     const SimCommandOptions& options) {
  auto view = std::make_unique<LiveView>(options.view_port);
  auto waiting = view_snapshot(scenario, world);
  waiting.mode = "sim";
  waiting.phase = "simulating";
  view->publish(std::move(waiting));
  spdlog::info("live view: {} (the in-process run is played back at run.rate_hz once it is done)",
               view->url());
  return view;
}

/// The Monte Carlo figures beyond the per-step tables.
struct MonteCarloFigures {
  double mean = 0.0;    ///< final RMSE, mean over trials
  double spread = 0.0;  ///< final RMSE, standard deviation over trials
  double mc_rmse = 0.0;
  double mc_bound = 0.0;
  double mc_optimum = 0.0;  ///< sqrt of the mean over trials of the optimum² of each trial's data
  std::ptrdiff_t trials_flagged = 0;
  std::ptrdiff_t trials_non_finite = 0;  ///< trials with a NaN/Inf estimate at some step: results not valid
};

/// Adds summary.json's "monte_carlo" block to the first trial's record and returns its figures.
MonteCarloFigures summarize_monte_carlo(sim::MonteCarloResult& result, const std::filesystem::path& run_dir) {
  MonteCarloFigures figures;
  double& mean = figures.mean;
  double sq = 0.0;
  for (double r : result.final_rmse_per_trial) mean += r, sq += r * r;
  mean /= result.trials;
  figures.spread = std::sqrt(std::max(0.0, sq / result.trials - mean * mean));
  auto& record = result.first_trial;
  record.wall_s = result.wall_s;
  record.extra["run_directory"] = run_dir.string();
  record.extra["monte_carlo"] = {{"trials", result.trials},
                                 {"threads", result.threads},
                                 {"wall_s", result.wall_s},
                                 {"final_rmse_mean_m", mean},
                                 {"final_rmse_std_m", figures.spread},
                                 {"final_mse_mean_m2", result.steps.back().mse_mean},
                                 {"final_nees_mean", result.steps.back().nees_mean}};
  // Trials with an agent whose self-check flags it at the final step (docs/algorithms.md §1.6).
  const auto& flagged = result.final_flagged_per_trial;
  figures.trials_flagged = std::count_if(flagged.begin(), flagged.end(), [](int f) { return f > 0; });
  record.extra["monte_carlo"]["trials_flagged"] = figures.trials_flagged;
  const auto& broken = result.non_finite_steps_per_trial;
  figures.trials_non_finite =
      std::count_if(broken.begin(), broken.end(), [](std::size_t s) { return s > 0; });
  record.extra["monte_carlo"]["trials_non_finite"] = figures.trials_non_finite;
  // MC RMSE = sqrt of the mean final squared error: the quantity the bound bounds.
  figures.mc_rmse = std::sqrt(result.steps.back().mse_mean);
  figures.mc_bound = result.steps.back().bound_rmse_m;
  auto finite_or_null = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
  record.extra["monte_carlo"]["mc_rmse_m"] = figures.mc_rmse;
  record.extra["monte_carlo"]["bound_kind"] = std::string(world::to_string(record.bound.kind));
  record.extra["monte_carlo"]["bound_rmse_m"] = finite_or_null(figures.mc_bound);
  record.extra["monte_carlo"]["bound_all_data_rmse_m"] =
      finite_or_null(result.steps.back().bound_all_data_rmse_m);
  record.extra["monte_carlo"]["ratio"] = finite_or_null(figures.mc_rmse / figures.mc_bound);
  // The optimum of each trial's own data (docs/algorithms.md §1.3.2): the pooled efficiency.
  double optimum_sq = 0.0;
  for (double o : result.final_optimum_per_trial) optimum_sq += o * o;
  figures.mc_optimum = std::sqrt(optimum_sq / result.trials);
  record.extra["monte_carlo"]["optimum_kind"] = std::string(world::to_string(record.optimum.kind));
  record.extra["monte_carlo"]["optimum_rmse_m"] = finite_or_null(figures.mc_optimum);
  record.extra["monte_carlo"]["efficiency"] = finite_or_null(figures.mc_rmse / figures.mc_optimum);
  return figures;
}

void print_monte_carlo(const sim::MonteCarloResult& result, const MonteCarloFigures& figures,
                       const std::filesystem::path& run_dir) {
  const auto& record = result.first_trial;
  std::printf("%s", rundir::result_table(record).c_str());
  std::printf(
      "  Monte Carlo: %d trials on %d threads in %.2f s; final RMSE %.4f ± %.4f m (mean ± std over "
      "trials)\n",
      result.trials, result.threads, result.wall_s, figures.mean, figures.spread);
  std::printf(
      "  Monte Carlo RMSE (sqrt of the mean final squared error) %.4f m; bound (%s) %.4f m; ratio %.2f\n",
      figures.mc_rmse, std::string(world::to_string(record.bound.kind)).c_str(), figures.mc_bound,
      figures.mc_rmse / figures.mc_bound);
  std::printf("  Monte Carlo optimum of each trial's data (%s) %.4f m; efficiency %.3f\n",
              std::string(world::to_string(record.optimum.kind)).c_str(), figures.mc_optimum,
              figures.mc_rmse / figures.mc_optimum);
  std::printf("  Monte Carlo: %lld of %d trials end with agents flagged by their self-check\n",
              static_cast<long long>(figures.trials_flagged), result.trials);
  if (figures.trials_non_finite > 0) {
    std::printf("  NOT VALID: %lld of %d trials hold non-finite (NaN/Inf) estimates\n",
                static_cast<long long>(figures.trials_non_finite), result.trials);
  }
  std::printf("  run directory: %s\n", run_dir.string().c_str());
}

/// --trials > 1: Monte Carlo over every core; writes the run directory and prints the summary.
int run_trials(const SimCommand& command) {
  const auto& options = command.options;
  auto& progress = command.progress;
  const auto started = command.started;
  auto result = sim::run_monte_carlo(
      command.scenario, options.trials, options.threads,
      [&](int done, int total) {
        progress.update("[" + std::to_string(static_cast<int>(seconds_since(started))) + "s] trials " +
                            std::to_string(done) + "/" + std::to_string(total),
                        done == total);
      },
      {}, &interrupted());
  progress.finish();
  const MonteCarloFigures figures = summarize_monte_carlo(result, command.run_dir);
  {
    const SlowPhaseNotice notice(options.progress, "writing the run directory");
    // summary.json is the run directory's last file: the Monte Carlo tables go first.
    sim::write_monte_carlo(command.run_dir, result);
    rundir::write_run_directory(command.run_dir, result.first_trial, command.control);
  }
  print_monte_carlo(result, figures, command.run_dir);
  return figures.trials_non_finite > 0 ? kExitInvalidResults : 0;
}

/// One in-process run's options: threads, --hostile, replay, Ctrl-C, progress and --record (into
/// `recorder`, which must outlive the run).
sim::SimOptions single_run_options(const SimCommand& command,
                                   std::unique_ptr<rundir::DirectoryRecorder>& recorder) {
  const auto& options = command.options;
  sim::SimOptions sim_options;
  // Results are identical for any count; unasked, large worlds use every core (auto_round_threads).
  sim_options.round_threads = options.threads;
  sim_options.trial = options.trial;
  sim_options.hostile_agents = options.hostile_agents;
  sim_options.recorded = options.recorded;
  sim_options.control = command.control;
  if (options.record) {
    recorder = std::make_unique<rundir::DirectoryRecorder>(command.run_dir);
    sim_options.recorder = recorder.get();
  }
  sim_options.on_step = [&progress = command.progress, &scenario = command.scenario,
                         started = command.started](std::int64_t step, const world::ErrorStats& errors) {
    progress.update(progress_line(step, scenario.run.steps, errors, scenario.world.agents,
                                  scenario.world.agents, seconds_since(started)),
                    step + 1 == scenario.run.steps);
    // The agent-clock and centralized runners poll no flag: they stop here, after a step, and write
    // nothing (the round runner returns the steps done instead).
    if (interrupted().load()) throw world::Cancelled();
  };
  return sim_options;
}

/// The single run's result table, its interruption, and --view's playback. The exit code.
int report_single_run(const SimCommand& command, const rundir::RunRecord& record, LiveView* view) {
  const auto& scenario = command.scenario;
  std::printf("%s", rundir::result_table(record).c_str());
  std::printf("  run directory: %s\n", command.run_dir.string().c_str());
  if (interrupted().load() && !record.interrupted) {
    std::fprintf(stderr, "interrupted while the run directory was written: it was completed first\n");
  }
  if (record.interrupted) {
    std::fprintf(stderr,
                 "interrupted after %zu of %d steps; the run directory holds them (interrupted: true)\n",
                 record.metrics.size(), scenario.run.steps);
    return 1;
  }
  const int code = rundir::non_finite_estimates(record).steps > 0 ? kExitInvalidResults : 0;
  if (view) {
    std::printf(
        "  live view: %s (playing back %zu steps at %g Hz, then serving the final state %s; Ctrl-C ends)\n",
        view->url().c_str(), record.metrics.size(), scenario.run.rate_hz,
        hold_text(command.options.view_hold_s).c_str());
    std::fflush(stdout);
    play_back(*view, scenario, record, interrupted());
    view->hold(command.options.view_hold_s, interrupted());
  }
  return code;
}

/// One in-process run on `world`: simulates, writes the run directory, reports.
int run_single(const SimCommand& command, world::World& world, LiveView* view) {
  const auto& scenario = command.scenario;
  const auto& options = command.options;
  std::unique_ptr<rundir::DirectoryRecorder> recorder;
  const sim::SimOptions sim_options = single_run_options(command, recorder);
  if (scenario.run.sim_clock == config::SimClock::kAgents ||
      config::runs_in_fusion_centre(scenario.algorithm.name))
    command.cancelled_when =
        "during the simulation (run.sim_clock: agents and centralized runs keep no partial run)";
  auto record = sim::run_simulation(scenario, std::move(world), sim_options);
  command.progress.finish();
  record.extra["run_directory"] = command.run_dir.string();
  if (recorder) {
    recorder->close();
    record.extra["recording"] = {
        {"file", rundir::kRecordingFile},
        {"steps", recorder->steps()},
        {"sample_log", std::string(rundir::kSampleLogDirectory) + "/" + rundir::kSimSampleLogFile},
        {"samples", recorder->samples()}};
  }
  if (options.trial > 0) record.extra["trial"] = options.trial;  // with the seed, what reproduces it
  for (const auto& [key, value] : options.summary_extra.items()) record.extra[key] = value;
  {
    const SlowPhaseNotice notice(options.progress, "writing the run directory");
    command.cancelled_when = "while the run directory was written: it is incomplete (no summary.json)";
    // After a Ctrl-C that stopped the simulation, the steps done are saved; a second one cancels that.
    world::WorkControl writing = command.control;
    if (record.interrupted) writing.cancel = &interrupted_again();
    rundir::write_run_directory(command.run_dir, record, writing);
  }
  return report_single_run(command, record, view);
}

}  // namespace

int run_sim_command(const SimCommandOptions& options) {
  auto scenario = load_scenario_or_report(options.scenario_path, options.overrides);
  return scenario ? run_sim_command(std::move(*scenario), options) : 2;
}

// By value as run_orchestrator(config::Scenario, ...), whose public signature it mirrors (orchestrator.hpp).
// NOLINTNEXTLINE(performance-unnecessary-value-param)
int run_sim_command(config::Scenario scenario, const SimCommandOptions& options) {
  // Ctrl-C (SIGINT, SIGTERM, SIGHUP) in every phase: building a 10^5-agent world alone takes minutes.
  install_interrupt_handlers();
  if (const int code = check_options(scenario, options); code != 0) return code;
  const auto run_dir = options.out_dir.empty() ? rundir::default_run_directory(scenario) : options.out_dir;
  if (options.view_port >= 0 && options.trials > 1) {
    std::fprintf(stderr, "error: --view shows one run; it cannot be combined with --trials\n");
    return 2;
  }
  Progress progress(options.progress);
  const auto started = Clock::now();
  const world::WorkControl control = interruptible_work(progress, started);
  std::error_code ignored;
  const bool run_dir_existed = std::filesystem::exists(run_dir, ignored);
  const char* cancelled_when = "before the first step; nothing written";
  const SimCommand command{scenario, options, run_dir, progress, started, control, cancelled_when};
  try {
    rundir::prepare_run_directory(run_dir, options.force);
    // The world is built once (the check's world is the run's), after the run directory is known to be
    // writable: a bad --out is reported at once, not after minutes of work.
    world::World world = check_runnable(scenario, control, options.trial);
    std::unique_ptr<LiveView> view;
    if (options.view_port >= 0) view = start_view(scenario, world, options);
    if (options.trials > 1) {
      world = {};  // each trial builds its own
      cancelled_when = "during the trials; nothing written (an unfinished Monte Carlo run writes nothing)";
      return run_trials(command);
    }
    return run_single(command, world, view.get());
  } catch (const world::Cancelled&) {
    progress.finish();
    discard_if_empty(run_dir, run_dir_existed);
    std::fprintf(stderr, "interrupted %s\n", cancelled_when);
    return 1;
  } catch (const config::ScenarioError& error) {
    discard_if_empty(run_dir, run_dir_existed);
    std::fprintf(stderr, "error: %s\n", error.what());
    return 2;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 1;
  }
}

}  // namespace swarmloc::orchestrator
