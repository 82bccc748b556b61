// `swarmloc sim`: the in-process runner behind the same run directory and result table as `run`.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
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

}  // namespace

int run_sim_command(const SimCommandOptions& options) {
  config::Scenario scenario;
  try {
    scenario = config::load_scenario(options.scenario_path, options.overrides);
  } catch (const config::ScenarioError& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 2;
  }
  return run_sim_command(std::move(scenario), options);
}

int run_sim_command(config::Scenario scenario, const SimCommandOptions& options) {
  // Ctrl-C (SIGINT, SIGTERM, SIGHUP) in every phase: building a 10^5-agent world alone takes minutes.
  install_interrupt_handlers();
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
  if ((options.record || options.recorded) && options.trials > 1) {
    std::fprintf(stderr,
                 "error: --record and replay are single runs; they cannot be combined with --trials\n");
    return 2;
  }
  const auto run_dir = options.out_dir.empty() ? sim::default_run_directory(scenario) : options.out_dir;
  if (options.view_port >= 0 && options.trials > 1) {
    std::fprintf(stderr, "error: --view shows one run; it cannot be combined with --trials\n");
    return 2;
  }
  Progress progress(options.progress);
  const auto started = Clock::now();
  const sim::WorkControl control = interruptible_work(progress, started);
  std::error_code ignored;
  const bool run_dir_existed = std::filesystem::exists(run_dir, ignored);
  const char* cancelled_when = "before the first step; nothing written";
  try {
    sim::prepare_run_directory(run_dir, options.force);
    // The world is built once (the check's world is the run's), after the run directory is known to be
    // writable: a bad --out is reported at once, not after minutes of work.
    sim::World world = check_runnable(scenario, control);
    std::unique_ptr<LiveView> view;
    if (options.view_port >= 0) {
      view = std::make_unique<LiveView>(options.view_port);
      auto waiting = view_snapshot(scenario, world);
      waiting.mode = "sim";
      waiting.phase = "simulating";
      view->publish(std::move(waiting));
      spdlog::info("live view: {} (the in-process run is played back at run.rate_hz once it is done)",
                   view->url());
    }
    if (options.trials > 1) {
      world = {};  // each trial builds its own
      cancelled_when = "during the trials; nothing written (an unfinished Monte Carlo run writes nothing)";
      auto result = sim::run_monte_carlo(
          scenario, options.trials, options.threads,
          [&](int done, int total) {
            progress.update("[" + std::to_string(static_cast<int>(seconds_since(started))) + "s] trials " +
                                std::to_string(done) + "/" + std::to_string(total),
                            done == total);
          },
          {}, &interrupted());
      progress.finish();
      double mean = 0.0, sq = 0.0;
      for (double r : result.final_rmse_per_trial) mean += r, sq += r * r;
      mean /= result.trials;
      const double spread = std::sqrt(std::max(0.0, sq / result.trials - mean * mean));
      auto& record = result.first_trial;
      record.wall_s = result.wall_s;
      record.extra["run_directory"] = run_dir.string();
      record.extra["monte_carlo"] = {{"trials", result.trials},
                                     {"threads", result.threads},
                                     {"wall_s", result.wall_s},
                                     {"final_rmse_mean_m", mean},
                                     {"final_rmse_std_m", spread},
                                     {"final_mse_mean_m2", result.steps.back().mse_mean},
                                     {"final_nees_mean", result.steps.back().nees_mean}};
      // Trials with an agent whose self-check flags it at the final step (docs/algorithms.md §1.6).
      const auto& flagged = result.final_flagged_per_trial;
      const auto trials_flagged = std::count_if(flagged.begin(), flagged.end(), [](int f) { return f > 0; });
      record.extra["monte_carlo"]["trials_flagged"] = trials_flagged;
      // MC RMSE = sqrt of the mean final squared error: the quantity the bound bounds.
      const double mc_rmse = std::sqrt(result.steps.back().mse_mean);
      const double mc_bound = result.steps.back().bound_rmse_m;
      auto finite_or_null = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
      record.extra["monte_carlo"]["mc_rmse_m"] = mc_rmse;
      record.extra["monte_carlo"]["bound_kind"] = std::string(sim::to_string(record.bound.kind));
      record.extra["monte_carlo"]["bound_rmse_m"] = finite_or_null(mc_bound);
      record.extra["monte_carlo"]["bound_all_data_rmse_m"] =
          finite_or_null(result.steps.back().bound_all_data_rmse_m);
      record.extra["monte_carlo"]["ratio"] = finite_or_null(mc_rmse / mc_bound);
      {
        const SlowPhaseNotice notice(options.progress, "writing the run directory");
        // summary.json is the run directory's last file: the Monte Carlo tables go first.
        sim::write_monte_carlo(run_dir, result);
        sim::write_run_directory(run_dir, record, control);
      }
      std::printf("%s", sim::result_table(record).c_str());
      std::printf(
          "  Monte Carlo: %d trials on %d threads in %.2f s; final RMSE %.4f ± %.4f m (mean ± std over "
          "trials)\n",
          result.trials, result.threads, result.wall_s, mean, spread);
      std::printf(
          "  Monte Carlo RMSE (sqrt of the mean final squared error) %.4f m; bound (%s) %.4f m; ratio %.2f\n",
          mc_rmse, std::string(sim::to_string(record.bound.kind)).c_str(), mc_bound, mc_rmse / mc_bound);
      std::printf("  Monte Carlo: %lld of %d trials end with agents flagged by their self-check\n",
                  static_cast<long long>(trials_flagged), result.trials);
      std::printf("  run directory: %s\n", run_dir.string().c_str());
      return 0;
    }
    sim::SimOptions sim_options;
    // Results are identical for any count; unasked, large worlds use every core (auto_round_threads).
    sim_options.round_threads = options.threads;
    sim_options.hostile_agents = options.hostile_agents;
    sim_options.recorded = options.recorded;
    sim_options.control = control;
    std::unique_ptr<sim::DirectoryRecorder> recorder;
    if (options.record) {
      recorder = std::make_unique<sim::DirectoryRecorder>(run_dir);
      sim_options.recorder = recorder.get();
    }
    sim_options.on_step = [&](std::int64_t step, const sim::ErrorStats& errors) {
      progress.update(progress_line(step, scenario.run.steps, errors, scenario.world.agents,
                                    scenario.world.agents, seconds_since(started)),
                      step + 1 == scenario.run.steps);
      // The agent-clock and centralized runners poll no flag: they stop here, after a step, and write
      // nothing (the round runner returns the steps done instead).
      if (interrupted().load()) throw sim::Cancelled();
    };
    if (scenario.run.sim_clock == config::SimClock::kAgents || sim::is_centralized(scenario.algorithm.name))
      cancelled_when =
          "during the simulation (run.sim_clock: agents and centralized runs keep no partial run)";
    auto record = sim::run_simulation(scenario, std::move(world), sim_options);
    progress.finish();
    record.extra["run_directory"] = run_dir.string();
    if (recorder) {
      recorder->close();
      record.extra["recording"] = {
          {"file", sim::kRecordingFile},
          {"steps", recorder->steps()},
          {"sample_log", std::string(sim::kSampleLogDirectory) + "/" + sim::kSimSampleLogFile},
          {"samples", recorder->samples()}};
    }
    for (const auto& [key, value] : options.summary_extra.items()) record.extra[key] = value;
    {
      const SlowPhaseNotice notice(options.progress, "writing the run directory");
      cancelled_when = "while the run directory was written: it is incomplete (no summary.json)";
      // After a Ctrl-C that stopped the simulation, the steps done are saved; a second one cancels that.
      sim::WorkControl writing = control;
      if (record.interrupted) writing.cancel = &interrupted_again();
      sim::write_run_directory(run_dir, record, writing);
    }
    std::printf("%s", sim::result_table(record).c_str());
    std::printf("  run directory: %s\n", run_dir.string().c_str());
    if (interrupted().load() && !record.interrupted) {
      std::fprintf(stderr, "interrupted while the run directory was written: it was completed first\n");
    }
    if (record.interrupted) {
      std::fprintf(stderr,
                   "interrupted after %zu of %d steps; the run directory holds them (interrupted: true)\n",
                   record.metrics.size(), scenario.run.steps);
      return 1;
    }
    if (view) {
      std::printf(
          "  live view: %s (playing back %zu steps at %g Hz, then serving the final state %s; Ctrl-C ends)\n",
          view->url().c_str(), record.metrics.size(), scenario.run.rate_hz,
          hold_text(options.view_hold_s).c_str());
      std::fflush(stdout);
      play_back(*view, scenario, record, interrupted());
      view->hold(options.view_hold_s, interrupted());
    }
    return 0;
  } catch (const sim::Cancelled&) {
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
