#include "orchestrator.hpp"

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <memory>
#include <thread>

#include "launcher.hpp"
#include "live_view.hpp"
#include "swarmloc/dds/transport.hpp"
#include "swarmloc/sim/centralized_runner.hpp"
#include "swarmloc/sim/recording.hpp"
#include "swarmloc/sim/simulator.hpp"
#include "swarmloc/sim/world.hpp"

namespace swarmloc::orchestrator {
namespace {

using Clock = std::chrono::steady_clock;

std::atomic<bool> g_interrupted{false};
void on_signal(int /*signal*/) { g_interrupted.store(true); }  // flag only; never DDS from a handler

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

/// "for 10 s" / "until Ctrl-C" (--view-hold).
std::string hold_text(double seconds) {
  if (!std::isfinite(seconds)) return "until Ctrl-C";
  char text[64];
  std::snprintf(text, sizeof text, "for %g s", seconds);
  return text;
}

/// One progress line, rewritten in place on a terminal.
class Progress {
 public:
  explicit Progress(bool enabled) : enabled_(enabled), tty_(isatty(STDERR_FILENO) != 0) {}
  void update(const std::string& line, bool force = false) {
    if (!enabled_) return;
    const auto now = Clock::now();
    if (!force && now - last_ < std::chrono::milliseconds(tty_ ? 250 : 5000)) return;
    last_ = now;
    std::fprintf(stderr, tty_ ? "\r%-100s" : "%s\n", line.c_str());
    std::fflush(stderr);
  }
  void finish() {
    if (enabled_ && tty_) std::fprintf(stderr, "\n");
  }

 private:
  bool enabled_;
  bool tty_;
  Clock::time_point last_ = Clock::now() - std::chrono::hours(1);
};

std::string progress_line(std::int64_t step, int steps, const sim::ErrorStats& errors, int reporting,
                          int agents, double elapsed_s) {
  char line[200];
  std::snprintf(line, sizeof line,
                "[%5.1fs] step %4lld/%d  rmse %8.4f m  max %8.4f m  agents reporting %d/%d", elapsed_s,
                static_cast<long long>(step + 1), steps, errors.rmse_m, errors.max_error_m, reporting,
                agents);
  return line;
}

sim::World make_world(const config::Scenario& scenario, const RunOptions& options) {
  sim::World world = sim::build_world(scenario);
  sim::attach_recorded(world, options.recorded);
  return world;
}

class Orchestrator {
 public:
  Orchestrator(config::Scenario scenario, RunOptions options, std::filesystem::path run_dir)
      : scenario_(std::move(scenario)),
        options_(std::move(options)),
        run_dir_(std::move(run_dir)),
        world_(make_world(scenario_, options_)),
        centralized_(sim::is_centralized(scenario_.algorithm.name)),
        lockstep_(scenario_.run.mode == config::RunMode::kLockstep && !centralized_),
        lockstep_excluded_(static_cast<std::size_t>(scenario_.world.agents), false),
        kills_(config::parse_agent_faults(scenario_.faults.kill, "faults.kill", false)),
        pauses_(config::parse_agent_faults(scenario_.faults.pause, "faults.pause", true)),
        down_(static_cast<std::size_t>(scenario_.world.agents), false),
        incarnation_(static_cast<std::size_t>(scenario_.world.agents), 0),
        launcher_index_(static_cast<std::size_t>(scenario_.world.agents), -1),
        progress_(options_.progress) {}

  int run() {
    const auto started = Clock::now();
    const int n = world_.size();
    latest_.assign(static_cast<std::size_t>(n), std::nullopt);
    reports_.assign(static_cast<std::size_t>(n), std::nullopt);
    record_.scenario = scenario_;
    record_.mode = lockstep_ ? "dds-lockstep" : "dds-free-run";
    record_.agents = n;
    record_.anchors = world_.anchor_count();
    record_.mean_degree = world_.mean_degree();
    record_.crlb = sim::scenario_crlb(world_, scenario_);

    if (options_.view_port >= 0) start_view();
    if (options_.record) {
      recording_ = std::make_unique<sim::RecordingWriter>(run_dir_ / sim::kRecordingFile, scenario_, world_);
    }
    dds::OrchestratorTransport transport(scenario_, n);
    if (options_.launch_agents) {
      const auto launch_start = std::chrono::steady_clock::now();
      launch_agents();
      spdlog::info("launched {} processes in {:.2f} s", launcher_.size(),
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - launch_start).count());
    }
    spdlog::info("run directory {}: {} agents ({} anchors, mean degree {:.1f}), {} steps at {} Hz{}",
                 run_dir_.string(), n, record_.anchors, record_.mean_degree, scenario_.run.steps,
                 scenario_.run.rate_hz,
                 centralized_ ? " (" + scenario_.algorithm.name + " in a fusion centre)" : std::string());

    const bool ready = wait_for_agents(transport, started);
    bool failed = !ready;
    const auto world_phase_start = Clock::now();
    if (ready) failed = !drive(transport, started);
    // The world's own rate: below run.rate_hz when the orchestrator cannot keep up (docs/scale.md).
    if (ready) record_.extra["world_steps_s"] = seconds_since(world_phase_start);
    // Let the last estimates arrive, then stop everyone.
    publish_view("settling");
    const auto settle_until =
        Clock::now() + std::chrono::duration<double>(failed ? 0.0 : scenario_.run.settle_s);
    while (Clock::now() < settle_until && !g_interrupted.load()) collect(transport, 0.05);
    sim::ControlMessage stop;
    stop.command = sim::ControlCommand::kStop;
    stop.header.agent_id = kOrchestratorId;
    transport.publish_control(stop);
    if (ready) record_.world_phase_s = seconds_since(world_phase_start);
    collect(transport, 0.3);
    finish_scoring();
    launcher_.stop_all(5.0);
    record_.processes = launcher_.size() + 1;
    record_.interrupted = g_interrupted.load();
    record_.wall_s = seconds_since(started);
    if (options_.launch_agents) {
      for (std::size_t i = 0; i < record_.agent_summaries.size() && i < launcher_index_.size(); ++i) {
        // The newest incarnation's exit code (a killed-and-not-restarted agent: 128 + 9).
        if (launcher_index_[i] >= 0)
          record_.agent_summaries[i].exit_code = launcher_.exit_code(launcher_index_[i]);
      }
    }
    record_.extra["rejected_reports"] = transport.rejected_reports();
    if (lockstep_) record_.extra["lockstep_timeouts"] = lockstep_timeouts_;
    record_.extra["run_directory"] = run_dir_.string();
    if (recording_) {
      recording_->close();
      record_.extra["recording"] = {
          {"file", sim::kRecordingFile},
          {"steps", recording_->steps()},
          {"sample_logs", std::string(sim::kSampleLogDirectory) + "/agent_<id>.slrec"}};
    }
    for (const auto& [key, value] : options_.summary_extra.items()) record_.extra[key] = value;
    sim::write_run_directory(run_dir_, record_);
    publish_view(record_.interrupted || failed ? "stopped" : "done", true);  // done: summary.json is written
    progress_.finish();
    std::printf("%s", sim::result_table(record_).c_str());
    std::printf("  run directory: %s\n", run_dir_.string().c_str());
    const int code = record_.interrupted ? 1 : (failed ? 1 : 0);
    if (view_ && !g_interrupted.load()) {
      std::printf("  live view: %s (serving the final state %s; Ctrl-C ends)\n", view_->url().c_str(),
                  hold_text(options_.view_hold_s).c_str());
      std::fflush(stdout);
      view_->hold(options_.view_hold_s, g_interrupted);
    }
    return code;
  }

 private:
  void start_view() {
    view_ = std::make_unique<LiveView>(options_.view_port);
    spdlog::info("live view: {}", view_->url());
    publish_view("waiting for agents");
  }

  /// The live view's snapshot: truth, the scored estimates, link counters, the last scored step.
  void publish_view(const char* phase, bool done = false) {
    if (!view_) return;
    ViewSnapshot snapshot = view_snapshot(scenario_, world_);
    snapshot.mode = "dds";
    snapshot.phase = phase;
    snapshot.done = done;
    for (std::size_t i = 0; i < reports_.size(); ++i) {
      const auto& report = reports_[i];
      if (!report) continue;
      if (report->steps_run > 0) snapshot.agents[i].estimate = latest_[i];
      for (const auto& link : report->links)
        add_link_counters(snapshot, link.sender, static_cast<AgentId>(i), link);
    }
    if (!record_.metrics.empty()) set_metrics(snapshot, record_.metrics.back());
    view_->publish(std::move(snapshot));
  }

  void launch_agents() {
    std::filesystem::create_directories(run_dir_ / "logs");
    for (AgentId i = 0; i < world_.size(); ++i) launch_agent(i, 0);
    const auto scenario_file = (run_dir_ / "scenario.yaml").string();
    if (centralized_) {
      // Launched last, so the agents keep launcher indices 0 … N−1 (their summaries' exit codes).
      const auto log = (run_dir_ / "logs" / "fusion_center.log").string();
      launcher_.launch(
          {options_.agent_binary, "agent", "--role", "fusion", "--scenario", scenario_file, "--log", log},
          log + ".out", scenario_.run.agent_nice);
    }
  }

  /// Starts agent `id`'s process (incarnation > 0: a restart after faults.kill, with its own log).
  void launch_agent(AgentId id, int incarnation) {
    const auto scenario_file = (run_dir_ / "scenario.yaml").string();
    char name[48];
    if (incarnation == 0) {
      std::snprintf(name, sizeof name, "agent_%03d.log", id);
    } else {
      std::snprintf(name, sizeof name, "agent_%03d.restart%d.log", id, incarnation);
    }
    const auto log = (run_dir_ / "logs" / name).string();
    std::vector<std::string> argv{options_.agent_binary, "agent", "--scenario", scenario_file, "--id",
                                  std::to_string(id),    "--log", log};
    // The agent rebuilds the world from the scenario; telling it which draw was accepted spares it the
    // localizability check (~20 ms of CPU per agent at N = 500, all of them starting at once).
    if (scenario_.world.source == config::WorldSource::kGenerated)
      argv.insert(argv.end(), {"--world-draw", std::to_string(world_.placement_attempts - 1)});
    if (incarnation > 0) argv.insert(argv.end(), {"--incarnation", std::to_string(incarnation)});
    if (options_.record) {
      std::string file = name;  // agent_003.log -> recording/agent_003.slrec
      file.replace(file.size() - 4, 4, ".slrec");
      argv.insert(argv.end(), {"--record", (run_dir_ / sim::kSampleLogDirectory / file).string()});
    }
    if (std::find(options_.hostile_agents.begin(), options_.hostile_agents.end(), id) !=
        options_.hostile_agents.end()) {
      argv.emplace_back("--hostile");
    }
    launcher_index_[static_cast<std::size_t>(id)] =
        launcher_.launch(argv, log + ".out", scenario_.run.agent_nice);
  }

  /// faults.kill / faults.pause at world step `step` (free run: real signals to real processes).
  void apply_faults(std::int64_t step) {
    if (!options_.launch_agents) return;  // agents started elsewhere: not ours to signal
    for (const auto& fault : kills_) {
      const auto k = static_cast<std::size_t>(fault.agent);
      if (fault.from_step == step && launcher_.running(launcher_index_[k])) {
        launcher_.kill(launcher_index_[k], SIGKILL);
        down_[k] = true;
        reports_[k].reset();
        latest_[k].reset();
        spdlog::warn("fault: killed agent {} (kill -9) at step {}", fault.agent, step);
      }
      if (fault.to_step == step) {
        launch_agent(fault.agent, ++incarnation_[k]);
        down_[k] = false;
        spdlog::warn("fault: restarted agent {} at step {} (incarnation {}, fresh state)", fault.agent, step,
                     incarnation_[k]);
      }
    }
    for (const auto& fault : pauses_) {
      const auto k = static_cast<std::size_t>(fault.agent);
      if (fault.from_step == step) {
        launcher_.kill(launcher_index_[k], SIGSTOP);
        down_[k] = true;
        spdlog::warn("fault: paused agent {} (SIGSTOP) at step {}", fault.agent, step);
      }
      if (fault.to_step == step) {
        launcher_.kill(launcher_index_[k], SIGCONT);
        down_[k] = false;
        spdlog::warn("fault: resumed agent {} (SIGCONT) at step {}", fault.agent, step);
      }
    }
  }

  /// Waits until every agent has said hello (its first estimate report). False on timeout / interrupt.
  bool wait_for_agents(dds::OrchestratorTransport& transport, Clock::time_point started) {
    const int n = world_.size();
    const auto deadline = Clock::now() + std::chrono::duration<double>(scenario_.run.startup_timeout_s);
    while (!g_interrupted.load()) {
      collect(transport, 0.1);
      const int reporting = count_reporting();
      progress_.update(
          "[" + std::to_string(static_cast<int>(seconds_since(started))) +
          "s] waiting for agents: " + std::to_string(reporting) + "/" + std::to_string(n) + " reporting, " +
          std::to_string(transport.agents_listening()) + " listening" +
          (centralized_ ? (fusion_ready_ ? ", fusion centre up" : ", fusion centre not yet") : ""));
      // Also wait until our control and measurement writers have matched every agent's readers: with
      // N >= 150 the hub discovers an agent's estimate writer (hello) well before its readers, and a
      // START written then was never delivered to them (docs/scale.md, runs B-G).
      if (reporting == n && (!centralized_ || fusion_ready_) && transport.agents_listening() >= n) break;
      if (options_.launch_agents && launcher_.poll() < launcher_.size()) {
        spdlog::error("an agent process exited during start-up; see {}/logs", run_dir_.string());
        return false;
      }
      if (Clock::now() > deadline) {
        spdlog::error("only {}/{} agents{} reported within run.startup_timeout_s = {} s", reporting, n,
                      centralized_ && !fusion_ready_ ? " (and not the fusion centre)" : "",
                      scenario_.run.startup_timeout_s);
        return false;
      }
    }
    if (g_interrupted.load()) return false;
    // Neighbour discovery is scoped and fast (~0.1–0.4 s, reference/discovery.md); give it a moment.
    const auto grace_until = Clock::now() + std::chrono::milliseconds(1000);
    while (Clock::now() < grace_until) collect(transport, 0.05);
    sim::ControlMessage start;
    start.command = sim::ControlCommand::kStart;
    start.header.agent_id = kOrchestratorId;
    start.scenario_hash = config::scenario_hash(scenario_);
    transport.publish_control(start);
    spdlog::info("all {} agents reporting after {:.1f} s; START", n, seconds_since(started));
    return true;
  }

  /// The world loop. False on interrupt.
  bool drive(dds::OrchestratorTransport& transport, Clock::time_point started) {
    const auto period = std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(1.0 / scenario_.run.rate_hz));
    auto next = Clock::now();
    for (std::int64_t step = 0; step < scenario_.run.steps; ++step) {
      if (g_interrupted.load()) return false;
      if (step > 0) sim::advance_truth(world_, scenario_, step);
      apply_faults(step);
      const auto stamp_ns =
          static_cast<std::int64_t>(static_cast<double>(step) / scenario_.run.rate_hz * 1e9);
      std::vector<estimators::MeasurementBatch> batches;
      batches.reserve(static_cast<std::size_t>(world_.size()));
      for (AgentId i = 0; i < world_.size(); ++i)
        batches.push_back(sim::generate_batch(world_, scenario_, i, step));
      if (recording_) recording_->append_step(step, world_.truth, batches);
      transport.publish_batches(
          sim::Header{kOrchestratorId, static_cast<std::uint32_t>(step), step, stamp_ns, stamp_ns}, batches);
      if (lockstep_) {
        wait_for_step(transport, step);
      } else {
        next += period;
        while (Clock::now() < next && !g_interrupted.load()) {
          collect(transport, std::chrono::duration<double>(next - Clock::now()).count());
        }
      }
      score_step(step);
      publish_view("running");
      progress_.update(progress_line(step, scenario_.run.steps, record_.metrics.back().errors,
                                     count_reporting(), world_.size(), seconds_since(started)),
                       step + 1 == scenario_.run.steps);
    }
    return true;
  }

  /// Lockstep barrier: waits until every agent has reported step `step` done (it acknowledged its
  /// samples first), so the next batch finds every neighbour's step data in place. An agent that
  /// misses the deadline is warned about and no longer waited for.
  void wait_for_step(dds::OrchestratorTransport& transport, std::int64_t step) {
    const double limit_s = std::max(5.0, 50.0 / scenario_.run.rate_hz);
    const auto deadline = Clock::now() + std::chrono::duration<double>(limit_s);
    auto done = [&](std::size_t i) {
      return lockstep_excluded_[i] || down_[i] ||
             (reports_[i] && static_cast<std::int64_t>(reports_[i]->steps_run) >= step + 1);
    };
    while (!g_interrupted.load()) {
      bool all = true;
      for (std::size_t i = 0; i < reports_.size() && all; ++i) all = done(i);
      if (all) return;
      if (Clock::now() > deadline) {
        for (std::size_t i = 0; i < reports_.size(); ++i) {
          if (done(i)) continue;
          lockstep_excluded_[i] = true;
          ++lockstep_timeouts_;
          spdlog::warn("lockstep: agent {} did not finish step {} within {:.1f} s; no longer waiting for it",
                       i, step, limit_s);
        }
        return;
      }
      collect(transport, 0.02);
    }
  }

  void collect(dds::OrchestratorTransport& transport, double timeout_s) {
    for (auto& report : transport.wait_and_take_estimates(std::max(0.0, timeout_s))) {
      const AgentId id = report.header.agent_id;
      if (id == dds::kFusionCenterId) {
        fusion_ready_ = true;  // the fusion centre's hello; its estimates carry each agent's id
        continue;
      }
      if (id < 0 || id >= world_.size()) continue;  // unknown agent id: not scored
      auto& slot = reports_[static_cast<std::size_t>(id)];
      if (slot && report.steps_run < slot->steps_run) continue;  // older than what we hold
      latest_[static_cast<std::size_t>(id)] = report.estimate;
      slot = std::move(report);
    }
  }

  int count_reporting() const {
    int count = 0;
    for (const auto& r : reports_) count += r.has_value() ? 1 : 0;
    return count;
  }

  void score_step(std::int64_t step) {
    // Scored only once the agent has run at least one step (hello reports carry the prior).
    std::vector<std::optional<estimators::Estimate>> scored(latest_.size());
    for (std::size_t i = 0; i < latest_.size(); ++i) {
      // Dead or paused agents are not scored (their last estimate is not a living agent's).
      if (reports_[i] && reports_[i]->steps_run > 0 && !down_[i]) scored[i] = latest_[i];
    }
    sim::StepMetrics metrics;
    metrics.step = step;
    metrics.time_s = sim::reported_time_s(scenario_, step);
    metrics.errors = sim::score(world_, scored);
    metrics.crlb_rmse_m = record_.crlb.accumulated_rmse_m(static_cast<double>(step + 1));
    record_.metrics.push_back(metrics);
    for (std::size_t i = 0; i < scored.size(); ++i) {
      if (scored[i])
        record_.estimates.push_back(
            {step, static_cast<AgentId>(i), *scored[i], world_.scored_truth(static_cast<AgentId>(i))});
    }
  }

  /// After the settle time: re-score the last step with the newest estimates; gather counters.
  void finish_scoring() {
    if (!record_.metrics.empty()) {
      const auto last_step = record_.metrics.back().step;
      record_.metrics.pop_back();
      while (!record_.estimates.empty() && record_.estimates.back().step == last_step)
        record_.estimates.pop_back();
      score_step(last_step);
      if (centralized_) {
        // E-A2's total MSE (ALGORITHMS.md §2.8): every agent, beacons included, at the final step.
        std::vector<std::optional<estimators::Estimate>> scored(latest_.size());
        for (std::size_t i = 0; i < latest_.size(); ++i) {
          if (reports_[i] && reports_[i]->steps_run > 0) scored[i] = latest_[i];
        }
        record_.extra["final_total_mse_m2"] = sim::total_squared_error(world_.truth, scored);
        record_.extra["fusion_center"] = {
            {"filter", scenario_.algorithm.name},
            {"bandwidth", sim::kCentralizedBandwidth},
            {"estimated_agents",
             std::count_if(scored.begin(), scored.end(), [](const auto& e) { return e.has_value(); })}};
      }
    }
    for (AgentId i = 0; i < world_.size(); ++i) {
      sim::AgentSummary summary;
      summary.agent = i;
      summary.anchor = world_.is_anchor[static_cast<std::size_t>(i)];
      if (const auto& report = reports_[static_cast<std::size_t>(i)]) {
        summary.steps_run = report->steps_run;
        summary.samples_published = report->samples_published;
        summary.samples_published_in_steps = report->samples_published_in_steps;
        summary.cpu_s = report->cpu_s;
        summary.rejected_by_reason = report->rejected_by_reason;
        for (const auto& link : report->links) record_.links[{link.sender, i}] = link;
      }
      record_.agent_summaries.push_back(summary);
    }
  }

  config::Scenario scenario_;
  RunOptions options_;
  std::filesystem::path run_dir_;
  sim::World world_;
  bool centralized_ = false;  ///< the algorithm runs in a fusion-centre process
  /// run.mode = lockstep: the next batch goes out once every agent finished the step (the fusion
  /// centre of a centralized algorithm already consumes complete world steps).
  bool lockstep_ = false;
  std::vector<bool> lockstep_excluded_;
  int lockstep_timeouts_ = 0;
  std::vector<config::AgentFault> kills_;   ///< faults.kill
  std::vector<config::AgentFault> pauses_;  ///< faults.pause
  std::vector<bool> down_;                  ///< killed or paused now: not scored, not waited for
  std::vector<int> incarnation_;            ///< restarts so far per agent
  std::vector<int> launcher_index_;         ///< the launcher's index of each agent's newest process
  bool fusion_ready_ = false;               ///< the fusion centre has said hello
  Progress progress_;
  ProcessLauncher launcher_;
  sim::RunRecord record_;
  std::vector<std::optional<estimators::Estimate>> latest_;
  std::vector<std::optional<sim::EstimateReport>> reports_;
  std::unique_ptr<LiveView> view_;                   ///< --view
  std::unique_ptr<sim::RecordingWriter> recording_;  ///< --record
};

void check_hostile_ids(const std::vector<AgentId>& hostile_agents, const config::Scenario& scenario) {
  for (AgentId id : hostile_agents) {
    if (id < 0 || id >= scenario.world.agents) {
      throw config::ScenarioError("--hostile: agent " + std::to_string(id) + " is outside [0, world.agents)");
    }
  }
}

}  // namespace

/// Builds the world and one agent's estimator, so that an unplaceable world or an algorithm this
/// runtime cannot run yet is reported as bad input (exit 2) naming the key.
static void check_runnable(const config::Scenario& scenario) {
  const auto world = sim::build_world(scenario);
  try {
    (void)sim::make_agent_estimator(scenario, world, 0);
  } catch (const std::invalid_argument& error) {
    throw config::ScenarioError("algorithm.name: '" + scenario.algorithm.name +
                                "' is not runnable by swarmloc run/sim yet (" + error.what() + ")");
  }
}

int run_orchestrator(const RunOptions& options) {
  config::Scenario scenario;
  try {
    scenario = config::load_scenario(options.scenario_path, options.overrides);
  } catch (const config::ScenarioError& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 2;
  }
  return run_orchestrator(std::move(scenario), options);
}

int run_orchestrator(config::Scenario scenario, const RunOptions& options) {
  try {
    check_hostile_ids(options.hostile_agents, scenario);
    check_runnable(scenario);  // placement and algorithm errors are bad input, found before anything starts
    dds::require_ports_fit(scenario);
    if (!scenario.dds.security_dir.empty()) {
      // Agents read the run directory's scenario.yaml, possibly from another working directory.
      scenario.dds.security_dir = std::filesystem::absolute(scenario.dds.security_dir).lexically_normal();
      dds::security_files(scenario.dds.security_dir, kOrchestratorId);
      if (options.launch_agents) {
        for (AgentId id = 0; id < scenario.world.agents; ++id)
          dds::security_files(scenario.dds.security_dir, id);
        if (sim::is_centralized(scenario.algorithm.name)) {
          dds::security_files(scenario.dds.security_dir, dds::kFusionCenterId);
        }
      }
    }
  } catch (const config::ScenarioError& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 2;
  }
  const auto run_dir = options.out_dir.empty() ? sim::default_run_directory(scenario) : options.out_dir;
  std::filesystem::create_directories(run_dir);
  {
    // Agents read the scenario as run (overrides applied, defaults filled) from the run directory.
    std::ofstream out(run_dir / "scenario.yaml");
    out << config::to_yaml(scenario);
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  try {
    Orchestrator orchestrator(scenario, options, run_dir);
    return orchestrator.run();
  } catch (const std::exception& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 1;
  }
}

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
  try {
    check_hostile_ids(options.hostile_agents, scenario);
    check_runnable(scenario);
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
  try {
    std::unique_ptr<LiveView> view;
    if (options.view_port >= 0) {
      view = std::make_unique<LiveView>(options.view_port);
      std::signal(SIGINT, on_signal);
      std::signal(SIGTERM, on_signal);
      auto waiting = view_snapshot(scenario, sim::build_world(scenario));
      waiting.mode = "sim";
      waiting.phase = "simulating";
      view->publish(std::move(waiting));
      spdlog::info("live view: {} (the in-process run is played back at run.rate_hz once it is done)",
                   view->url());
    }
    Progress progress(options.progress);
    const auto started = Clock::now();
    if (options.trials > 1) {
      auto result = sim::run_monte_carlo(scenario, options.trials, options.threads, [&](int done, int total) {
        progress.update("[" + std::to_string(static_cast<int>(seconds_since(started))) + "s] trials " +
                            std::to_string(done) + "/" + std::to_string(total),
                        done == total);
      });
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
      sim::write_run_directory(run_dir, record);
      sim::write_monte_carlo(run_dir, result);
      std::printf("%s", sim::result_table(record).c_str());
      std::printf(
          "  Monte Carlo: %d trials on %d threads in %.2f s; final RMSE %.4f ± %.4f m (mean ± std over "
          "trials)\n",
          result.trials, result.threads, result.wall_s, mean, spread);
      std::printf("  run directory: %s\n", run_dir.string().c_str());
      return 0;
    }
    sim::SimOptions sim_options;
    // Results are identical for any count; unasked, large worlds use every core (auto_round_threads).
    sim_options.round_threads = options.threads;
    sim_options.hostile_agents = options.hostile_agents;
    sim_options.recorded = options.recorded;
    std::unique_ptr<sim::DirectoryRecorder> recorder;
    if (options.record) {
      recorder = std::make_unique<sim::DirectoryRecorder>(run_dir);
      sim_options.recorder = recorder.get();
    }
    sim_options.on_step = [&](std::int64_t step, const sim::ErrorStats& errors) {
      progress.update(progress_line(step, scenario.run.steps, errors, scenario.world.agents,
                                    scenario.world.agents, seconds_since(started)),
                      step + 1 == scenario.run.steps);
    };
    auto record = sim::run_simulation(scenario, sim_options);
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
    sim::write_run_directory(run_dir, record);
    std::printf("%s", sim::result_table(record).c_str());
    std::printf("  run directory: %s\n", run_dir.string().c_str());
    if (view) {
      std::printf(
          "  live view: %s (playing back %zu steps at %g Hz, then serving the final state %s; Ctrl-C ends)\n",
          view->url().c_str(), record.metrics.size(), scenario.run.rate_hz,
          hold_text(options.view_hold_s).c_str());
      std::fflush(stdout);
      play_back(*view, scenario, record, g_interrupted);
      view->hold(options.view_hold_s, g_interrupted);
    }
    return 0;
  } catch (const config::ScenarioError& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 2;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 1;
  }
}

}  // namespace swarmloc::orchestrator
