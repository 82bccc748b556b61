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
#include <optional>
#include <set>
#include <thread>

#include "agent_launch.hpp"
#include "console.hpp"
#include "launcher.hpp"
#include "live_view.hpp"
#include "run_setup.hpp"
#include "swarmloc/dds/transport.hpp"
#include "swarmloc/run/fusion_centre.hpp"
#include "swarmloc/run/manifests.hpp"
#include "swarmloc/rundir/recording.hpp"
#include "swarmloc/runtime/liveness.hpp"
#include "swarmloc/runtime/process_cpu.hpp"
#include "swarmloc/runtime/report_book.hpp"
#include "swarmloc/runtime/run_health.hpp"
#include "swarmloc/runtime/world_pacing.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::orchestrator {
namespace {

world::World with_recording(world::World world, const RunOptions& options) {
  world::attach_recorded(world, options.recorded);
  return world;
}

class Orchestrator {
 public:
  Orchestrator(config::Scenario scenario, RunOptions options, std::filesystem::path run_dir,
               world::World world)
      : scenario_(std::move(scenario)),
        options_(std::move(options)),
        run_dir_(std::move(run_dir)),
        world_(with_recording(std::move(world), options_)),
        centralized_(config::runs_in_fusion_centre(scenario_.algorithm.name)),
        lockstep_(scenario_.run.mode == config::RunMode::kLockstep && !centralized_),
        lockstep_excluded_(static_cast<std::size_t>(scenario_.world.agents), false),
        kills_(config::parse_agent_faults(scenario_.faults.kill, "faults.kill", false)),
        pauses_(config::parse_agent_faults(scenario_.faults.pause, "faults.pause", true)),
        down_(static_cast<std::size_t>(scenario_.world.agents), false),
        incarnation_(static_cast<std::size_t>(scenario_.world.agents), 0),
        launcher_index_(static_cast<std::size_t>(scenario_.world.agents), -1),
        progress_(options_.progress),
        results_hash_(config::results_hash(scenario_)),
        liveness_(scenario_.world.agents, liveness_limits(scenario_, lockstep_)) {}

  int run() {
    const auto started = origin_;
    const int n = world_.size();
    start_record(n);
    progress_.update(starting_line(scenario_), true);  // the first line a user sees says what starts
    if (options_.view_port >= 0) start_view();
    if (options_.record) {
      recording_ =
          std::make_unique<rundir::RecordingWriter>(run_dir_ / rundir::kRecordingFile, scenario_, world_);
    }
    // Before our own participant binds its port: a busy block means another run on this domain.
    dds::require_ports_free(scenario_, options_.launch_agents);
    spdlog::info("run id {} (dds.run_id: every partition name starts with it)", scenario_.dds.run_id);
    if (!lockstep_) priority_ = raise_world_priority();  // before the participant: its threads inherit it
    dds::OrchestratorTransport transport(scenario_, n);
    // Agents started elsewhere take their manifest over DDS: offered until the run ends.
    const auto offered = offer_manifests(scenario_, write_manifests(), options_.launch_agents);
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
    const double cpu_at_start = runtime::process_cpu_s();
    if (ready) failed = !drive(transport, started);
    if (ready) {  // the world's own rate, and where its time went (docs/scale.md, "The world loop")
      record_.extra["world_steps_s"] = seconds_since(world_phase_start);
      record_.extra["orchestrator"] = profile_.to_json(runtime::process_cpu_s() - cpu_at_start);
      record_.extra["orchestrator"]["priority"] = priority_;
    }
    settle_and_stop(transport, ready, failed, world_phase_start);
    runtime::lower_to_normal_priority();  // the plots' gnuplot and the optimum's solve need no priority
    finish_scoring();
    rundir::update_run_optimum(record_, true);
    launcher_.stop_all(5.0);
    const runtime::RunHealth health = complete_record(transport, started, ready);
    rundir::write_run_directory(run_dir_, record_);
    return report_result(health, failed);
  }

 private:
  /// What the run record knows before the run: the scenario, the mode and the world's shape.
  void start_record(int n) {
    reports_ = runtime::ReportBook(n);
    record_.scenario = scenario_;
    record_.mode = lockstep_ ? "dds-lockstep" : "dds-free-run";
    record_.agents = n;
    record_.anchors = world_.anchor_count();
    record_.mean_degree = world_.mean_degree();
    rundir::compute_run_bounds(record_, world_);
  }

  /// After the world steps (or a failed start): the settle time (none after a failure), STOP, the last
  /// reports.
  void settle_and_stop(dds::OrchestratorTransport& transport, bool ready, bool failed,
                       Clock::time_point world_phase_start) {
    // Let the last estimates arrive, then stop everyone.
    publish_view("settling");
    const auto settle_until =
        Clock::now() + std::chrono::duration<double>(failed ? 0.0 : scenario_.run.settle_s);
    while (Clock::now() < settle_until && !interrupted().load()) {
      collect(transport, 0.05);
      if (ready) watch_processes(scenario_.run.steps - 1);
    }
    runtime::ControlMessage stop;
    stop.command = runtime::ControlCommand::kStop;
    stop.header.agent_id = kOrchestratorId;
    transport.publish_control(stop);
    if (ready) record_.world_phase_s = seconds_since(world_phase_start);
    collect(transport, 0.3);
  }

  /// The run record's closing figures (processes, exit codes, liveness, health, recording); the health.
  runtime::RunHealth complete_record(const dds::OrchestratorTransport& transport, Clock::time_point started,
                                     bool ready) {
    record_.processes = launcher_.size() + 1;
    record_.interrupted = interrupted().load();
    record_.wall_s = seconds_since(started);
    if (options_.launch_agents) {
      for (std::size_t i = 0; i < record_.agent_summaries.size() && i < launcher_index_.size(); ++i) {
        // The newest incarnation's exit code (a killed-and-not-restarted agent: 128 + 9).
        if (launcher_index_[i] >= 0)
          record_.agent_summaries[i].exit_code = launcher_.exit_code(launcher_index_[i]);
      }
    }
    record_.extra["rejected_reports"] = transport.rejected_reports();
    record_.extra["liveness"] = liveness_.to_json();
    if (fusion_exit_) record_.extra["liveness"]["fusion_center_ended"] = *fusion_exit_;
    if (!refused_.empty()) record_.extra["refused_agents"] = refused_json();
    runtime::RunHealth health = assess_health(ready);
    if (!start_failure_.empty()) {
      health.healthy = false;
      health.reasons.insert(health.reasons.begin(), start_failure_);
    }
    record_.extra["health"] = runtime::to_json(health);
    // A run that never started has no results: its summary must not read as a healthy one (exit 1).
    if (!start_failure_.empty()) record_.extra["health"]["verdict"] = "failed";
    if (lockstep_) record_.extra["lockstep_timeouts"] = lockstep_timeouts_;
    record_.extra["run_directory"] = run_dir_.string();
    if (world_.trial > 0) record_.extra["trial"] = world_.trial;  // with the seed, what reproduces it
    if (recording_) {
      recording_->close();
      record_.extra["recording"] = {
          {"file", rundir::kRecordingFile},
          {"steps", recording_->steps()},
          {"sample_logs", std::string(rundir::kSampleLogDirectory) + "/agent_<id>.slrec"}};
    }
    for (const auto& [key, value] : options_.summary_extra.items()) record_.extra[key] = value;
    return health;
  }

  /// Once summary.json is written: the result table, the health, the live view's final state. The exit code.
  int report_result(const runtime::RunHealth& health, bool failed) {
    publish_view(record_.interrupted || failed ? "stopped" : "done", true);  // done: summary.json is written
    progress_.finish();
    std::printf("%s", rundir::result_table(record_).c_str());
    if (start_failure_.empty()) {
      print_health(health);
    } else {
      std::printf("  health: FAILED (%s)\n", start_failure_.c_str());
    }
    std::printf("  run directory: %s\n", run_dir_.string().c_str());
    // 3: completed, but not representative of the configured system (README, exit codes).
    const int code = record_.interrupted || failed ? 1 : (health.healthy ? 0 : 3);
    if (view_ && !interrupted().load()) {
      std::printf("  live view: %s (serving the final state %s; Ctrl-C ends)\n", view_->url().c_str(),
                  hold_text(options_.view_hold_s).c_str());
      std::fflush(stdout);
      view_->hold(options_.view_hold_s, interrupted());
    }
    return code;
  }
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
    snapshot.bound_kind = std::string(world::to_string(record_.bound.kind));
    snapshot.phase = phase;
    snapshot.done = done;
    for (std::size_t i = 0; i < reports_.size(); ++i) {
      const auto& report = reports_[i];
      if (!report) continue;
      if (report->steps_run > 0) snapshot.agents[i].estimate = report->estimate;
      for (const auto& link : report->links)
        add_link_counters(snapshot, link.sender, static_cast<AgentId>(i), link);
    }
    if (!record_.metrics.empty()) set_metrics(snapshot, record_.metrics.back());
    set_optimum(snapshot, record_);
    view_->publish(std::move(snapshot));
  }

  void launch_agents() {
    std::filesystem::create_directories(run_dir_ / "logs");
    for (AgentId i = 0; i < world_.size(); ++i) launch_agent(i, 0);
    if (centralized_) {
      // Launched last, so the agents keep launcher indices 0 … N−1 (their summaries' exit codes).
      const ProcessCommand fusion = fusion_centre_process(launch_plan());
      fusion_index_ = launcher_.launch(fusion.argv, fusion.output_path, scenario_.run.agent_nice);
    }
  }

  /// <run>/manifests/agent_<id>.json: what each agent may know, computed once from our world. Written for
  /// agents started elsewhere too (containers that mount the run directory).
  std::vector<runtime::AgentManifest> write_manifests() const {
    auto manifests = run::make_agent_manifests(scenario_, world_, world_.trial);
    for (const auto& manifest : manifests)
      runtime::write_manifest(runtime::manifest_path(run_dir_, manifest.id), manifest);
    return manifests;
  }

  [[nodiscard]] LaunchPlan launch_plan() const {
    return {run_dir_, options_.agent_binary, options_.record, options_.hostile_agents};
  }

  /// Starts agent `id`'s process (incarnation > 0: a restart after faults.kill, with its own log).
  void launch_agent(AgentId id, int incarnation) {
    const ProcessCommand command = agent_process(launch_plan(), id, incarnation);
    launcher_index_[static_cast<std::size_t>(id)] =
        launcher_.launch(command.argv, command.output_path, scenario_.run.agent_nice);
  }

  /// faults.kill / faults.pause at world step `step` (free run: real signals to real processes).
  void apply_faults(std::int64_t step) {
    if (!options_.launch_agents) return;  // agents started elsewhere: not ours to signal
    for (const auto& fault : kills_) {
      const auto k = static_cast<std::size_t>(fault.agent);
      if (fault.from_step == step && launcher_.running(launcher_index_[k])) {
        expected_exits_.insert(launcher_index_[k]);
        launcher_.kill(launcher_index_[k], SIGKILL);
        down_[k] = true;
        liveness_.scheduled_down(fault.agent);
        reports_.killed(fault.agent);
        spdlog::warn("fault: killed agent {} (kill -9) at step {}", fault.agent, step);
      }
      if (fault.to_step == step) {
        launch_agent(fault.agent, ++incarnation_[k]);
        reports_.restarted(fault.agent);
        down_[k] = false;
        liveness_.scheduled_up(fault.agent, seconds_since(origin_), true);
        spdlog::warn("fault: restarted agent {} at step {} (incarnation {}, fresh state)", fault.agent, step,
                     incarnation_[k]);
      }
    }
    for (const auto& fault : pauses_) {
      const auto k = static_cast<std::size_t>(fault.agent);
      if (fault.from_step == step) {
        launcher_.kill(launcher_index_[k], SIGSTOP);
        down_[k] = true;
        liveness_.scheduled_down(fault.agent);
        spdlog::warn("fault: paused agent {} (SIGSTOP) at step {}", fault.agent, step);
      }
      if (fault.to_step == step) {
        launcher_.kill(launcher_index_[k], SIGCONT);
        down_[k] = false;
        liveness_.scheduled_up(fault.agent, seconds_since(origin_), false);
        spdlog::warn("fault: resumed agent {} (SIGCONT) at step {}", fault.agent, step);
      }
    }
  }

  /// Waits until every agent has said hello (its first estimate report). False on timeout / interrupt.
  bool wait_for_agents(dds::OrchestratorTransport& transport, Clock::time_point started) {
    const int n = world_.size();
    const auto deadline = Clock::now() + std::chrono::duration<double>(scenario_.run.startup_timeout_s);
    while (!interrupted().load()) {
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
        start_failure_ = "did not start: an agent process exited during start-up (its log is in logs/)";
        return false;
      }
      if (Clock::now() > deadline) {
        spdlog::error("only {}/{} agents{} reported within run.startup_timeout_s = {} s", reporting, n,
                      centralized_ && !fusion_ready_ ? " (and not the fusion centre)" : "",
                      scenario_.run.startup_timeout_s);
        start_failure_ = "did not start: only " + std::to_string(reporting) + "/" + std::to_string(n) +
                         " agents reported within run.startup_timeout_s";
        return false;
      }
    }
    if (interrupted().load()) return false;
    // Neighbour discovery is scoped and fast (~0.1–0.4 s, docs/measurements/discovery.md); give it a moment.
    const auto grace_until = Clock::now() + std::chrono::milliseconds(1000);
    while (Clock::now() < grace_until) collect(transport, 0.05);
    runtime::ControlMessage start;
    start.command = runtime::ControlCommand::kStart;
    start.header.agent_id = kOrchestratorId;
    start.scenario_hash = results_hash_;
    transport.publish_control(start);
    liveness_.started(seconds_since(origin_));
    spdlog::info("all {} agents reporting after {:.1f} s; START", n, seconds_since(started));
    return true;
  }

  /// The world loop. False on interrupt.
  bool drive(dds::OrchestratorTransport& transport, Clock::time_point started) {
    const auto period = std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(1.0 / scenario_.run.rate_hz));
    auto next = Clock::now();
    using Phase = runtime::StepProfile::Phase;
    const auto mark = [this](Phase phase) {
      profile_.end_phase(phase, seconds_since(origin_), runtime::thread_cpu_s());
    };
    for (std::int64_t step = 0; step < scenario_.run.steps; ++step) {
      if (interrupted().load()) return false;
      current_step_ = step;
      const double lateness_s = lockstep_ ? 0.0 : std::chrono::duration<double>(Clock::now() - next).count();
      profile_.begin_step(seconds_since(origin_), runtime::thread_cpu_s(), lateness_s);
      if (step > 0) world::advance_truth(world_, scenario_, step);
      apply_faults(step);
      const auto stamp_ns =
          static_cast<std::int64_t>(static_cast<double>(step) / scenario_.run.rate_hz * 1e9);
      std::vector<estimators::MeasurementBatch> batches;
      batches.reserve(static_cast<std::size_t>(world_.size()));
      for (AgentId i = 0; i < world_.size(); ++i)
        batches.push_back(world::generate_batch(world_, scenario_, i, step));
      if (recording_) recording_->append_step(step, world_.truth, batches);
      rundir::observe_world_step(record_, step, world_, batches);
      mark(Phase::kGenerate);
      transport.publish_batches(
          runtime::Header{kOrchestratorId, static_cast<std::uint32_t>(step), step, stamp_ns, stamp_ns},
          batches);
      transport.publish_ros2_world(step, stamp_ns, world_.truth, world_.altitude, batches);  // docs/ros2.md
      mark(Phase::kPublish);
      if (lockstep_) {
        wait_for_step(transport, step);
      } else {
        next += period;
        runtime::take_when_due(
            next, [&] { collect(transport, 0.0); }, interrupted());
      }
      mark(Phase::kTake);
      watch_processes(step);
      score_step(step);
      // A checkpoint's optimum, for the live view; without one every solve waits until after STOP, so it
      // never delays a world step (docs/algorithms.md §1.3.2).
      if (view_) rundir::update_run_optimum(record_, false);
      publish_view("running");
      progress_.update(progress_line(step, scenario_.run.steps, record_.metrics.back().errors,
                                     current_agents_, world_.size(), seconds_since(started)),
                       step + 1 == scenario_.run.steps);
      mark(Phase::kScore);
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
    while (!interrupted().load()) {
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
      if (id != dds::kFusionCenterId && (id < 0 || id >= world_.size())) continue;  // unknown: not scored
      if (report.results_hash != results_hash_) {
        // A fusion centre's estimates carry each agent's id; its hello carries its own.
        refuse(centralized_ && report.steps_run > 0 ? dds::kFusionCenterId : id, report.results_hash,
               transport);
        continue;
      }
      if (id == dds::kFusionCenterId) {
        fusion_ready_ = true;  // the fusion centre's hello; its estimates carry each agent's id
        continue;
      }
      if (!reports_.take(std::move(report))) continue;  // older than what we hold, or a killed process's
      // A centralized run's agents only say hello (steps_run 0): the fusion centre's estimates are what
      // must stay current.
      if (!centralized_ || reports_[static_cast<std::size_t>(id)]->steps_run > 0)
        liveness_.heard(id, current_step_, seconds_since(origin_));
    }
  }

  int count_reporting() const {
    int count = 0;
    for (const auto& r : reports_) count += r.has_value() ? 1 : 0;
    return count;
  }

  /// Each death, stall and resumption once, when it is found.
  void log_liveness_events() {
    const auto& events = liveness_.events();
    for (; logged_events_ < events.size(); ++logged_events_) {
      const auto& e = events[logged_events_];
      if (e.kind == runtime::LivenessEvent::Kind::kResumed) {
        spdlog::warn("agent {} resumed at step {}: {}", e.agent, e.step, e.reason);
      } else {
        spdlog::warn("agent {} {} at step {}: {}; its estimate is not scored from now on", e.agent,
                     runtime::to_string(e.kind), e.step, e.reason);
      }
    }
  }

  /// Our children that ended outside the fault schedule (we are their parent: waitpid tells).
  void watch_processes(std::int64_t step) {
    if (!options_.launch_agents) return;
    launcher_.poll();
    const double now_s = seconds_since(origin_);
    for (AgentId i = 0; i < world_.size(); ++i) {
      const int index = launcher_index_[static_cast<std::size_t>(i)];
      if (index < 0 || launcher_.running(index) || !reaped_.insert(index).second) continue;
      if (expected_exits_.contains(index)) continue;
      liveness_.exited(i, step, now_s, launcher_.exit_code(index).value_or(-1));
    }
    if (fusion_index_ >= 0 && !launcher_.running(fusion_index_) && reaped_.insert(fusion_index_).second) {
      fusion_exit_ = runtime::describe_exit(launcher_.exit_code(fusion_index_).value_or(-1));
      spdlog::error("the fusion centre ended at step {} ({}); no agent is estimated any more", step,
                    *fusion_exit_);
    }
  }

  /// An agent (or fusion centre) whose scenario differs from ours is told so once, and never scored.
  void refuse(AgentId who, std::uint64_t their_hash, dds::OrchestratorTransport& transport) {
    if (!refused_.insert({who, their_hash}).second) return;
    const std::string name =
        who == dds::kFusionCenterId ? "the fusion centre" : "agent " + std::to_string(who);
    spdlog::error(
        "{} refused: its scenario (results hash {:016x}) differs from this run's ({:016x}); start it with {} "
        "and "
        "no --set that changes the world, the algorithm, the network, the clocks or the run",
        name, their_hash, results_hash_, (run_dir_ / "scenario.yaml").string());
    runtime::ControlMessage refusal;
    refusal.command = runtime::ControlCommand::kRefuse;
    refusal.header.agent_id = kOrchestratorId;
    refusal.target = who;
    refusal.scenario_hash = their_hash;
    transport.publish_control(refusal);
  }

  nlohmann::json refused_json() const {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& [who, hash] : refused_) {
      char text[24];
      std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(hash));
      out.push_back({{"agent", who}, {"results_hash", text}});
    }
    return out;
  }

  /// The run's verdict from the liveness events and everyone's timing (docs/robustness.md).
  [[nodiscard]] runtime::RunHealth assess_health(bool started) const {
    runtime::RunHealthInput input;
    input.free_run = !lockstep_;
    input.rate_hz = scenario_.run.rate_hz;
    input.world_steps = started ? static_cast<std::int64_t>(record_.metrics.size()) : 0;
    if (record_.extra.contains("world_steps_s"))
      input.world_steps_s = record_.extra["world_steps_s"].get<double>();
    input.late_world_steps = profile_.late_steps();
    input.max_world_step_lateness_s = profile_.max_lateness_s();
    input.unscheduled_deaths = liveness_.deaths() + (fusion_exit_ ? 1 : 0);
    input.stalls = liveness_.stalls();
    input.lockstep_timeouts = lockstep_timeouts_;
    input.non_finite_steps = rundir::non_finite_estimates(record_).steps;
    for (const auto& report : reports_) {
      if (report && report->health.ticks > 0) input.agents.push_back(report->health);
    }
    return runtime::assess_health(input);
  }

  static void print_health(const runtime::RunHealth& health) {
    std::printf("  health: %s\n",
                health.healthy ? "healthy" : "DEGRADED (completed; results not representative)");
    for (const auto& reason : health.reasons) std::printf("    - %s\n", reason.c_str());
  }

  /// `as_of_s`: the time currency is judged at (the final re-score judges at the last world step, so a
  /// fusion centre's last estimates, which arrive once and then stop, still count).
  void score_step(std::int64_t step, std::optional<double> as_of_s = std::nullopt) {
    // Scored only once the agent has run at least one step (hello reports carry the prior).
    const double now_s = seconds_since(origin_);
    liveness_.check(step, now_s);
    const double judged_s = as_of_s.value_or(now_s);
    if (!as_of_s) last_scored_at_s_ = now_s;
    std::vector<std::optional<estimators::Estimate>> scored(reports_.size());
    for (std::size_t i = 0; i < reports_.size(); ++i) {
      // Dead, paused, stalled or excluded agents are not scored: a stale estimate is not a living agent's.
      const bool current =
          !down_[i] && !lockstep_excluded_[i] && liveness_.current(static_cast<AgentId>(i), judged_s);
      if (reports_[i] && reports_[i]->steps_run > 0 && current) scored[i] = reports_[i]->estimate;
    }
    current_agents_ = static_cast<int>(
        std::count_if(scored.begin(), scored.end(), [](const auto& e) { return e.has_value(); }));
    log_liveness_events();
    rundir::StepMetrics metrics;
    metrics.lost = liveness_.lost_count();
    metrics.step = step;
    metrics.time_s = world::reported_time_s(scenario_, step);
    metrics.errors = world::score(world_, scored);
    rundir::note_scored_estimates(record_, scored);
    rundir::set_step_bounds(record_, metrics);
    record_.metrics.push_back(metrics);
    for (AgentId i = 0; i < static_cast<AgentId>(scored.size()); ++i) {
      const auto& estimate = scored[static_cast<std::size_t>(i)];
      if (estimate)
        record_.estimates.push_back({step, i, *estimate, world_.scored_truth(i), world_.scored_truth_z(i)});
    }
  }

  /// The run is over: every agent expected up and not scored at the last step is a stall. Agents the
  /// lockstep barrier excluded are counted in lockstep_timeouts, not here.
  void close_liveness(std::int64_t last_step) {
    std::vector<bool> stepped(reports_.size());
    for (std::size_t i = 0; i < reports_.size(); ++i) {
      stepped[i] = reports_[i] && reports_[i]->steps_run > 0;
      if (lockstep_excluded_[i]) liveness_.scheduled_down(static_cast<AgentId>(i));
    }
    liveness_.close(last_step, last_scored_at_s_, seconds_since(origin_), stepped);
  }

  /// After the settle time: re-score the last step with the newest estimates; gather counters.
  void finish_scoring() {
    if (!record_.metrics.empty()) {
      const auto last_step = record_.metrics.back().step;
      record_.metrics.pop_back();
      while (!record_.estimates.empty() && record_.estimates.back().step == last_step)
        record_.estimates.pop_back();
      if (!interrupted().load()) close_liveness(last_step);
      score_step(last_step, last_scored_at_s_);
      if (centralized_) {
        // E-A2's total MSE (docs/algorithms.md §2.8): every agent, beacons included, at the final step.
        std::vector<std::optional<estimators::Estimate>> scored(reports_.size());
        for (std::size_t i = 0; i < reports_.size(); ++i) {
          const bool current = liveness_.current(static_cast<AgentId>(i), last_scored_at_s_);
          if (reports_[i] && reports_[i]->steps_run > 0 && current) scored[i] = reports_[i]->estimate;
        }
        record_.extra["final_total_mse_m2"] = run::total_squared_error(world_.truth, scored, world_.altitude);
        record_.extra["fusion_center"] = {
            {"filter", scenario_.algorithm.name},
            {"bandwidth", run::centralized_bandwidth(world_.dimensions)},
            {"estimated_agents",
             std::count_if(scored.begin(), scored.end(), [](const auto& e) { return e.has_value(); })}};
      }
    }
    for (AgentId i = 0; i < world_.size(); ++i) {
      rundir::AgentSummary summary;
      summary.agent = i;
      summary.anchor = world_.is_anchor[static_cast<std::size_t>(i)];
      const auto fate = liveness_.fate(i);
      summary.fate = fate.status;
      summary.fate_step = fate.step;
      summary.fate_reason = fate.reason;
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
  world::World world_;
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
  std::string start_failure_;               ///< why the run did not start; empty if it did
  int fusion_index_ = -1;                   ///< the fusion centre's launcher index
  std::optional<std::string> fusion_exit_;  ///< how the fusion centre ended, if it did before STOP
  std::set<int> expected_exits_;            ///< launcher indices killed by faults.kill
  std::set<int> reaped_;                    ///< launcher indices whose end was already handled
  std::set<std::pair<AgentId, std::uint64_t>> refused_;  ///< (agent, its results hash) told REFUSE
  Progress progress_;
  Clock::time_point origin_ = Clock::now();  ///< the time origin of liveness and of the run's wall time
  std::uint64_t results_hash_;               ///< config::results_hash: agents must agree on it
  runtime::LivenessTracker liveness_;
  std::int64_t current_step_ = 0;
  std::size_t logged_events_ = 0;  ///< liveness events already logged
  double last_scored_at_s_ = 0.0;  ///< when the last world step was scored (the final re-score's time)
  int current_agents_ = 0;         ///< agents (anchors included) whose estimate was current at the last step
  runtime::StepProfile profile_{1.0 / scenario_.run.rate_hz};  ///< the world loop: lateness, where time goes
  std::string priority_ = "normal";  ///< the world loop's scheduling: "realtime" or "normal"
  ProcessLauncher launcher_;
  rundir::RunRecord record_;
  runtime::ReportBook reports_;
  std::unique_ptr<LiveView> view_;                      ///< --view
  std::unique_ptr<rundir::RecordingWriter> recording_;  ///< --record
};

}  // namespace

int run_orchestrator(config::Scenario scenario, const RunOptions& options) {
  // First: Ctrl-C must work while a large world is built (docs/robustness.md, "Large inputs").
  install_interrupt_handlers();
  Progress progress(options.progress);
  const auto started = Clock::now();
  const world::WorkControl control = interruptible_work(progress, started);
  std::filesystem::path run_dir;
  bool run_dir_existed = false;
  world::World world;
  try {
    world = prepare_run(scenario, options, control, run_dir, run_dir_existed);
    progress.finish();
  } catch (const world::Cancelled&) {
    progress.finish();
    discard_if_empty(run_dir, run_dir_existed);
    std::fprintf(stderr, "interrupted while the world was built; nothing written\n");
    return 1;
  } catch (const config::ScenarioError& error) {
    discard_if_empty(run_dir, run_dir_existed);
    std::fprintf(stderr, "error: %s\n", error.what());
    return 2;
  }
  // Launched agents read the run id from the run directory's scenario.yaml, so it is always fresh there.
  // Agents started elsewhere (--no-launch) may need a known one: an explicit dds.run_id is kept then.
  if (options.launch_agents || scenario.dds.run_id.empty()) scenario.dds.run_id = fresh_run_id();
  try {
    // Agents read the scenario as run (overrides applied, defaults filled) from the run directory.
    runtime::write_text_file(run_dir / "scenario.yaml", config::to_yaml(scenario));
    Orchestrator orchestrator(scenario, options, run_dir, std::move(world));
    return orchestrator.run();
  } catch (const std::exception& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 1;
  }
}

}  // namespace swarmloc::orchestrator
