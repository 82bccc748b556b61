#include "agent_node.hpp"

#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <map>
#include <memory>
#include <optional>
#include <thread>
#include <type_traits>

#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/dds/transport.hpp"
#include "swarmloc/runtime/agent_factory.hpp"
#include "swarmloc/runtime/agent_runtime.hpp"
#include "swarmloc/runtime/hostile.hpp"
#include "swarmloc/runtime/process_cpu.hpp"
#include "swarmloc/runtime/run_health.hpp"
#include "swarmloc/runtime/sample_log.hpp"

namespace swarmloc::agent {
namespace {

std::atomic<bool> g_stop_requested{false};

// Only sets a flag: never call DDS from a signal handler (docs/style.md, Cyclone section).
void on_signal(int /*signal*/) { g_stop_requested.store(true); }

using sim::process_cpu_s;

std::shared_ptr<spdlog::logger> make_logger(const AgentOptions& options) {
  const std::string name = options.id >= 0 ? "agent" + std::to_string(options.id) : std::string("agent");
  std::shared_ptr<spdlog::logger> logger;
  if (options.log_path.empty()) {
    logger = spdlog::stderr_color_mt(name);
  } else {
    logger = spdlog::basic_logger_mt(name, options.log_path, true);
  }
  logger->set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ [" + name + "] %v");
  logger->flush_on(spdlog::level::info);
  return logger;
}

class AgentProcess {
 public:
  AgentProcess(const config::Scenario& scenario, const sim::AgentManifest& manifest,
               const AgentOptions& options, std::shared_ptr<spdlog::logger> logger)
      : scenario_(scenario),
        options_(options),
        id_(manifest.id),
        logger_(std::move(logger)),
        clock_(manifest.clock),
        runtime_(sim::make_agent_estimator(scenario, manifest), manifest.setup, manifest.neighbours,
                 sim::make_runtime_params(manifest, options.incarnation)),
        transport_(scenario, dds::Topology{manifest.id, manifest.agent_count, manifest.neighbours}),
        neighbour_count_(static_cast<int>(manifest.neighbours.size())),
        sensor_only_(config::runs_in_fusion_centre(scenario.algorithm.name)),
        lockstep_(scenario.run.mode == config::RunMode::kLockstep && !sensor_only_),
        started_(std::chrono::steady_clock::now()),
        results_hash_(config::results_hash(scenario)),
        health_(1.0 / (scenario.run.rate_hz * scenario.run.agent_steps_per_world_step)) {
    for (const AgentId neighbour : manifest.neighbours)
      if (neighbour != manifest.id) last_heard_[neighbour] = std::nullopt;
    if (!options.record_path.empty()) {
      sample_log_ = std::make_unique<sim::SampleLogWriter>(options.record_path, manifest.agent_count,
                                                           config::scenario_hash(scenario));
    }
  }

  int run() {
    const TickPeriod period = tick_period();
    // Lockstep publishes its initial sample exactly once, when every neighbour can receive it, so that
    // sample numbers (and with them the seeded loss decisions) match the simulator's.
    if (!lockstep_) publish(runtime_.initial_publication(local_stamp_ns()));
    logger_->info("started: {} neighbours, clock offset {:+.3f} s drift {:+.1f} ppm{}{}", neighbour_count_,
                  clock_.offset_s, clock_.drift_ppm,
                  sensor_only_ ? " (sensor only: the fusion centre estimates)" : "",
                  lockstep_ ? " (lockstep: steps on each world step's batch)" : "");

    LoopTimers timers;
    timers.next_tick = std::chrono::steady_clock::now() +
                       std::chrono::duration_cast<std::chrono::steady_clock::duration>(period.tick);
    timers.last_hello = std::chrono::steady_clock::now() - std::chrono::seconds(10);
    timers.last_announcement = std::chrono::steady_clock::now();
    timers.last_batch_seen = std::chrono::steady_clock::now();
    timers.last_wake = std::chrono::steady_clock::now();
    while (!g_stop_requested.load()) {
      const auto now = std::chrono::steady_clock::now();
      // Lockstep wakes on data (the next batch); free run also on its own clock's tick.
      // Before START nothing is due sooner than the next hello (START itself wakes the wait).
      const double wait_s =
          !started_run_ ? 0.25
          : lockstep_   ? 0.1
                        : std::clamp(std::chrono::duration<double>(timers.next_tick - now).count(), 0.0, 0.1);
      auto inbound = transport_.wait_and_take(wait_s);
      const Verdict verdict = handle(inbound);
      if (verdict == Verdict::kRefused) return 2;
      if (verdict == Verdict::kStop) break;
      if (!inbound.batches.empty()) timers.last_batch_seen = std::chrono::steady_clock::now();

      const auto after = std::chrono::steady_clock::now();
      discount_own_pause(after, timers);
      log_matched(timers);
      if (!started_run_) {
        if (!await_start(after, period, timers)) return 1;
        continue;
      }
      step_when_due(after, period, timers);
      if (orchestrator_gone(after, period, timers)) break;
    }
    finish();
    return 0;
  }

 private:
  enum class Verdict { kContinue, kStop, kRefused };
  using SteadyTime = std::chrono::steady_clock::time_point;

  /// The step timer's period on the agent's own clock, and this agent's phase within it.
  struct TickPeriod {
    double local_s = 0.0;                  ///< one world period, local seconds (1 / run.rate_hz)
    std::chrono::duration<double> tick{};  ///< between two steps, in real (monotonic) time
    std::chrono::duration<double> phase{};
  };

  /// The run loop's timers.
  struct LoopTimers {
    SteadyTime next_tick;          ///< free run: when the next step is due
    SteadyTime last_hello;         ///< hellos (before START; sensor only: throughout) every 0.5 s
    SteadyTime last_announcement;  ///< free run before START: the initial state's last announcement
    SteadyTime last_batch_seen;    ///< the orchestrator-silence timer
    SteadyTime last_wake;          ///< the loop's previous pass (a long gap: we were not running)
    int last_matched = -1;         ///< neighbours matched when last logged
  };

  TickPeriod tick_period() const {
    TickPeriod period;
    period.local_s = 1.0 / scenario_.run.rate_hz;
    // The timer runs on the agent's own clock: a local period lasts period/(1+drift) in real time. It
    // steps run.agent_steps_per_world_step times per world period (one exchange each).
    period.tick = std::chrono::duration<double>(
        clock_.mono_duration(period.local_s / scenario_.run.agent_steps_per_world_step));
    // Agents are not synchronized: each starts ticking at its own phase within the first period.
    period.phase =
        std::chrono::duration<double>(sim::tick_phase_fraction(scenario_, id_) * period.tick.count());
    return period;
  }

  void log_matched(LoopTimers& timers) {
    // Logged from launch on: with DDS Security a participant that fails authentication never matches.
    const int matched = transport_.matched_neighbours();
    if (matched != timers.last_matched) {
      logger_->info("matched {}/{} neighbours", matched, neighbour_count_);
      timers.last_matched = matched;
    }
  }

  /// Before START: gets the initial state to the neighbours and says hello. False when START did not
  /// come within the start-up timeout (logged).
  bool await_start(SteadyTime after, const TickPeriod& period, LoopTimers& timers) {
    if (lockstep_ && !initial_published_ && transport_.neighbours_matched_both_ways()) {
      publish(runtime_.initial_publication(local_stamp_ns()));
      if (!transport_.wait_for_acks(kAckTimeoutS)) {
        logger_->warn("initial sample not acknowledged within {} s", kAckTimeoutS);
      }
      initial_published_ = true;
    }
    // Until START: announce the initial state whenever another neighbour's reader has matched
    // (best-effort samples written before that are lost to it), and every 5 s as a backstop. Each
    // announcement goes to every neighbour: at 5 Hz they kept 2 cores busy at N = 500 (docs/scale.md,
    // "Less chatter before START").
    if (!lockstep_) {
      const int readers = transport_.matched_neighbour_readers();
      if (readers > announced_to_ || after - timers.last_announcement > std::chrono::seconds(5)) {
        announced_to_ = std::max(announced_to_, readers);
        timers.last_announcement = after;
        publish(runtime_.initial_publication(local_stamp_ns()));
      }
    }
    // Say hello so the orchestrator can count us (lockstep: once the initial sample is with every
    // neighbour), but only once START and our measurements can reach us (control and measurement
    // readers matched): with N >= 150 an agent matched the orchestrator's one reader long before its
    // writers, said hello, and the orchestrator sent START to agents not yet listening. Repeated
    // every 0.5 s until the orchestrator's reader has acknowledged it: a hello written before that
    // reader matched ours is lost.
    if (after - timers.last_hello > std::chrono::milliseconds(500) && (!lockstep_ || initial_published_) &&
        transport_.orchestrator_matched() && !(hello_sent_ && transport_.reports_acknowledged())) {
      timers.last_hello = after;
      hello_sent_ = true;
      transport_.publish_estimate(report());
    }
    if (std::chrono::duration<double>(after - started_).count() > scenario_.run.startup_timeout_s + 30.0) {
      logger_->error("no START from the orchestrator within {:.0f} s; exiting",
                     scenario_.run.startup_timeout_s + 30.0);
      return false;
    }
    timers.next_tick =
        after + std::chrono::duration_cast<std::chrono::steady_clock::duration>(period.tick + period.phase);
    timers.last_batch_seen = after;  // the orchestrator-silence timer starts at START, not at launch
    return true;
  }

  /// After START: steps when due (free run: on our clock's tick; lockstep: on each world step's batch).
  void step_when_due(SteadyTime after, const TickPeriod& period, LoopTimers& timers) {
    if (sensor_only_) {
      // Centralized algorithm: the fusion centre estimates and reports every agent. Keep saying hello
      // (steps_run = 0, so these never replace the fusion centre's reports) and run no estimator.
      if (after - timers.last_hello > std::chrono::milliseconds(500)) {
        timers.last_hello = after;
        transport_.publish_estimate(report());
      }
      timers.next_tick = after + std::chrono::duration_cast<std::chrono::steady_clock::duration>(period.tick);
    } else if (lockstep_) {
      // One step per world-step batch, on the neighbours' samples of earlier steps only.
      if (runtime_.has_pending_batch()) {
        release_held(runtime_.steps_run());
        health_.on_tick(0.0, 0);  // lockstep steps on data, not on a schedule: nothing to be late for
        tick();
      }
    } else if (after >= timers.next_tick) {
      const double lateness_s = std::chrono::duration<double>(after - timers.next_tick).count();
      timers.next_tick += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period.tick);
      std::uint32_t missed = 0;
      if (timers.next_tick < after) {  // overran: do not burst to catch up
        missed = static_cast<std::uint32_t>(std::floor(lateness_s / period.tick.count()));
        timers.next_tick = after;
      }
      health_.on_tick(lateness_s, missed);
      tick();
    }
  }

  /// Between two passes lie one step and one wait of at most 0.25 s; a far longer gap means this process
  /// did not run (SIGSTOP, a starved machine), wherever in the loop it stopped. The orchestrator's silence
  /// counts only while we run: the silence timer moves on by the gap, never past now.
  static void discount_own_pause(SteadyTime after, LoopTimers& timers) {
    const auto gap = after - timers.last_wake;
    if (gap > std::chrono::seconds(1)) timers.last_batch_seen = std::min(timers.last_batch_seen + gap, after);
    timers.last_wake = after;
  }

  /// The orchestrator normally says STOP; if it vanished (crash, kill -9), do not linger. True (logged)
  /// when it has been silent too long.
  bool orchestrator_gone(SteadyTime after, const TickPeriod& period, const LoopTimers& timers) const {
    const double silent_s = std::chrono::duration<double>(after - timers.last_batch_seen).count();
    // Lockstep waits for the slowest agent every step: allow it the start-up timeout.
    const double silence_limit_s =
        lockstep_ ? scenario_.run.startup_timeout_s : std::max(5.0, 50.0 * period.local_s);
    if (silent_s > silence_limit_s) {
      logger_->warn("no measurements for {:.1f} s: orchestrator gone, exiting", silent_s);
      return true;
    }
    return false;
  }

  /// The last report, the diagnostics, and the sample log closed.
  void finish() {
    transport_.publish_estimate(report());
    log_diagnostics();
    if (sample_log_) {
      sample_log_->close();
      logger_->info("recorded {} inter-agent samples to {}", sample_log_->count(), options_.record_path);
    }
  }

  /// Feeds inbound samples to the runtime; STOP, or a refusal of our scenario, ends the run.
  Verdict handle(const dds::AgentInbound& inbound) {
    for (const auto& control : inbound.control) {
      if (control.target != kOrchestratorId && control.target != id_) continue;
      // A refusal names the hash it refuses: a corrected agent restarted under the same id ignores the
      // refusal its predecessor got (control samples are transient-local).
      const bool refused =
          control.command == sim::ControlCommand::kRefuse && control.scenario_hash == results_hash_;
      const bool foreign =
          control.command == sim::ControlCommand::kStart && control.scenario_hash != results_hash_;
      if (refused || foreign) {
        logger_->error(
            "refused by the orchestrator: this agent's scenario (results hash {:016x}) differs from the "
            "run's; "
            "start it with the run directory's scenario.yaml and no --set that changes the world, the "
            "algorithm, the network, the clocks or the run",
            results_hash_);
        return Verdict::kRefused;
      }
      if (control.command == sim::ControlCommand::kRefuse) continue;
      if (control.command == sim::ControlCommand::kStart && !started_run_) {
        started_run_ = true;
        cpu_at_start_ = process_cpu_s();
        transport_.reset_latency();
        logger_->info("CPU before START (start-up and discovery): {:.3f} s", cpu_at_start_);
        logger_->info("START received");
      } else if (control.command == sim::ControlCommand::kStop) {
        logger_->info("STOP received");
        return Verdict::kStop;
      }
    }
    if (sample_log_) record(inbound);
    note_arrivals(inbound);
    for (const auto& [header, batch] : inbound.batches) runtime_.on_batch(header, batch);
    if (lockstep_) {
      hold(inbound);
      return Verdict::kContinue;
    }
    for (const auto& sample : inbound.states)
      runtime_.on_state(sample.header, sample.message, sample.well_formed);
    for (const auto& sample : inbound.information) {
      runtime_.on_information(sample.header, sample.message, sample.well_formed);
    }
    for (const auto& sample : inbound.consensus)
      runtime_.on_consensus(sample.header, sample.message, sample.well_formed);
    for (const auto& sample : inbound.beliefs)
      runtime_.on_belief(sample.header, sample.message, sample.well_formed);
    return Verdict::kContinue;
  }

  /// Run health: when batches and each neighbour's samples arrived (docs/robustness.md).
  void note_arrivals(const dds::AgentInbound& inbound) {
    const auto now = std::chrono::steady_clock::now();
    for (std::size_t k = 0; k < inbound.batches.size(); ++k) {
      health_.on_batch(batch_waiting_since_.has_value());
      if (!batch_waiting_since_) batch_waiting_since_ = now;
    }
    auto heard = [&](const auto& samples) {
      for (const auto& sample : samples) {
        if (const auto it = last_heard_.find(sample.header.agent_id); it != last_heard_.end())
          it->second = now;
      }
    };
    heard(inbound.states);
    heard(inbound.information);
    heard(inbound.consensus);
    heard(inbound.beliefs);
  }

  /// Run health at a step: how long the used batch waited, how old each neighbour's newest sample is.
  void note_step() {
    const auto now = std::chrono::steady_clock::now();
    if (batch_waiting_since_) {
      health_.on_batch_used(std::chrono::duration<double>(now - *batch_waiting_since_).count());
      batch_waiting_since_.reset();
    }
    for (const auto& [neighbour, when] : last_heard_) {
      if (when) health_.on_neighbour_age(std::chrono::duration<double>(now - *when).count());
    }
  }

  /// The estimate report with what only the process knows: its scenario's hash and its timing.
  sim::EstimateReport report() const {
    auto r = runtime_.report(local_stamp_ns(), run_cpu_s());
    r.results_hash = results_hash_;
    r.health = health_.figures();
    return r;
  }

  /// --record: every inter-agent sample as taken, with its DDS source timestamp and take time.
  void record(const dds::AgentInbound& inbound) {
    auto append = [&](const auto& samples) {
      for (const auto& sample : samples) {
        sample_log_->append(sim::ReceivedSample{id_, runtime_.steps_run(), sample.source_timestamp_ns,
                                                sample.taken_ns, sample.well_formed, sample.header,
                                                sim::SampleMessage(sample.message)});
      }
    };
    append(inbound.states);
    append(inbound.information);
    append(inbound.consensus);
    append(inbound.beliefs);
  }

  /// Lockstep: keeps inter-agent samples until the step they belong to (a neighbour may already
  /// have run the step we are about to run).
  void hold(const dds::AgentInbound& inbound) {
    held_.states.insert(held_.states.end(), inbound.states.begin(), inbound.states.end());
    held_.information.insert(held_.information.end(), inbound.information.begin(), inbound.information.end());
    held_.consensus.insert(held_.consensus.end(), inbound.consensus.begin(), inbound.consensus.end());
    held_.beliefs.insert(held_.beliefs.end(), inbound.beliefs.begin(), inbound.beliefs.end());
  }

  /// Feeds the held samples published before step `step` to the runtime (in arrival order per family,
  /// as the simulator's bus delivers them) and keeps the rest.
  void release_held(std::int64_t step) {
    auto release = [&](auto& samples) {
      using Samples = std::decay_t<decltype(samples)>;
      Samples later;
      for (const auto& sample : samples) {
        if (sample.header.step < step) {
          runtime_.on_sample(sample.header, sample.message, sample.well_formed);
        } else {
          later.push_back(sample);
        }
      }
      samples = std::move(later);
    };
    release(held_.states);
    release(held_.information);
    release(held_.consensus);
    release(held_.beliefs);
  }

  void tick() {
    note_step();
    auto publication = runtime_.step(local_stamp_ns());
    if (options_.hostile) sim::make_hostile(publication.outbox, publication.header.step);
    publish(publication);
    // Lockstep: the report tells the orchestrator this step is done, so its samples must be with the
    // neighbours before it.
    if (lockstep_ && !transport_.wait_for_acks(kAckTimeoutS)) {
      logger_->warn("step {}: samples not acknowledged within {} s", publication.header.step, kAckTimeoutS);
    }
    // One report per world period is what the orchestrator scores; more would only load it.
    if (++ticks_since_report_ < scenario_.run.agent_steps_per_world_step) return;
    ticks_since_report_ = 0;
    transport_.publish_estimate(report());
  }

  void publish(const sim::AgentRuntime::Publication& publication) {
    sim::AgentRuntime::for_each_sample(publication, [this](const sim::Header& header, const auto& message) {
      using Message = std::decay_t<decltype(message)>;
      if constexpr (std::is_same_v<Message, estimators::StateMessage>)
        transport_.publish_state(header, message);
      if constexpr (std::is_same_v<Message, estimators::InformationMessage>)
        transport_.publish_information(header, message);
      if constexpr (std::is_same_v<Message, estimators::ConsensusMessage>)
        transport_.publish_consensus(header, message);
      if constexpr (std::is_same_v<Message, estimators::BeliefMessage>)
        transport_.publish_belief(header, message);
    });
  }

  /// CPU seconds spent since START: the steady-state cost the scaling figures compare (start-up and
  /// discovery are logged separately).
  double run_cpu_s() const { return started_run_ ? process_cpu_s() - cpu_at_start_ : 0.0; }

  std::int64_t local_stamp_ns() const {
    const double mono_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
    return static_cast<std::int64_t>(std::llround(clock_.local_time(mono_s) * 1e9));
  }

  void log_diagnostics() const {
    std::uint64_t arrived = 0, delivered = 0, dropped = 0, rejected = 0;
    for (const auto& [sender, link] : runtime_.links()) {
      arrived += link.arrived;
      delivered += link.delivered;
      dropped += link.dropped_injected;
      rejected += link.rejected;
    }
    logger_->info(
        "stopping after {} steps: arrived {} delivered {} dropped(injected) {} rejected {}; cpu {:.3f} s",
        runtime_.steps_run(), arrived, delivered, dropped, rejected, process_cpu_s());
    const dds::LatencySummary latency = transport_.inter_agent_latency();
    if (latency.samples > 0) {
      logger_->info(
          "inter-agent latency (source timestamp to take): p50 {:.1f} us p99 {:.1f} us over {} samples",
          latency.p50_us, latency.p99_us, latency.samples);
    }
    const auto& reasons = runtime_.rejected_by_reason();
    for (std::size_t r = 0; r < reasons.size(); ++r) {
      if (reasons[r] > 0)
        logger_->info("rejected {}: {}", sim::to_string(static_cast<sim::RejectReason>(r)), reasons[r]);
    }
  }

  const config::Scenario& scenario_;
  const AgentOptions& options_;
  AgentId id_ = 0;
  std::shared_ptr<spdlog::logger> logger_;
  core::ClockModel clock_;
  sim::AgentRuntime runtime_;
  dds::AgentTransport transport_;
  int neighbour_count_ = 0;
  bool sensor_only_ = false;  ///< centralized algorithm: batches only, no estimator steps
  bool lockstep_ = false;     ///< run.mode = lockstep: step on batches, not on the clock
  bool initial_published_ = false;
  bool hello_sent_ = false;     ///< before START: a hello was written (repeated until acknowledged)
  int announced_to_ = 0;        ///< free run before START: neighbour readers our last announcement reached
  int ticks_since_report_ = 0;  ///< run.agent_steps_per_world_step: estimate reports go every this many
  dds::AgentInbound held_;      ///< lockstep: samples of steps not yet run
  static constexpr double kAckTimeoutS = 5.0;
  bool started_run_ = false;
  double cpu_at_start_ = 0.0;
  std::chrono::steady_clock::time_point started_;
  std::unique_ptr<sim::SampleLogWriter> sample_log_;  ///< --record
  std::uint64_t results_hash_;                        ///< config::results_hash of our scenario
  sim::HealthMeter health_;
  std::optional<std::chrono::steady_clock::time_point> batch_waiting_since_;  ///< oldest unused batch
  /// Each neighbour's newest sample, taken at (empty: not heard yet).
  std::map<AgentId, std::optional<std::chrono::steady_clock::time_point>> last_heard_;
};

}  // namespace

namespace {

/// The scenario and the manifest must describe the same run, and --id (if given) the manifest's agent.
void check_manifest(config::Scenario& scenario, const sim::AgentManifest& manifest,
                    const AgentOptions& options) {
  if (options.id >= 0 && options.id != manifest.id) {
    throw sim::ManifestError("--id " + std::to_string(options.id) + " but the manifest is agent " +
                             std::to_string(manifest.id) + "'s");
  }
  if (config::results_hash(scenario) != manifest.results_hash) {
    throw sim::ManifestError(
        "the manifest was written for another scenario (results hash differs): start the agent with the run "
        "directory's scenario.yaml and no --set that changes the world, the algorithm, the network, the "
        "clocks or the run");
  }
  if (scenario.dds.run_id.empty()) scenario.dds.run_id = manifest.run_id;  // the manifest names the run
  if (scenario.dds.run_id != manifest.run_id) {
    throw sim::ManifestError("dds.run_id " + scenario.dds.run_id + " but the manifest belongs to run " +
                             manifest.run_id);
  }
  if (!scenario.dds.security_dir.empty()) dds::security_files(scenario.dds.security_dir, manifest.id);
}

/// The scenario and manifest, checked; nullopt (logged) on bad input.
std::optional<std::pair<config::Scenario, sim::AgentManifest>> load_inputs(
    const AgentOptions& options, const ManifestSource& manifest_source, spdlog::logger& logger) {
  try {
    // Without --scenario the defaults and --set tell where to wait for the manifest sample.
    config::Scenario scenario = options.scenario_path.empty()
                                    ? config::parse_scenario("{}", options.overrides, "--set")
                                    : config::load_scenario(options.scenario_path, options.overrides);
    sim::AgentManifest manifest = manifest_source(scenario, options);
    check_manifest(scenario, manifest, options);
    return std::make_pair(std::move(scenario), std::move(manifest));
  } catch (const config::ScenarioError& error) {
    logger.error("{}", error.what());
  } catch (const sim::ManifestError& error) {
    logger.error("{}", error.what());
  }
  return std::nullopt;
}

}  // namespace

int run_agent(const AgentOptions& options, const ManifestSource& manifest_source) {
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::signal(SIGHUP, on_signal);
  std::signal(SIGPIPE, SIG_IGN);
  auto logger = make_logger(options);
  std::optional<std::pair<config::Scenario, sim::AgentManifest>> inputs;
  try {
    inputs = load_inputs(options, manifest_source, *logger);
  } catch (const dds::DdsError& error) {  // no manifest sample came (or no participant for the wait)
    logger->error("runtime failure: {}", error.what());
    return 1;
  }
  if (!inputs) return 2;
  try {
    AgentProcess process(inputs->first, inputs->second, options, logger);
    return process.run();
  } catch (const std::exception& error) {
    logger->error("runtime failure: {}", error.what());
    return 1;
  }
}

}  // namespace swarmloc::agent
