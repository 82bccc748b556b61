#include "agent_node.hpp"

#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <memory>
#include <optional>

#include "dds_port.hpp"
#include "swarmloc/dds/transport.hpp"
#include "swarmloc/runtime/agent_factory.hpp"
#include "swarmloc/runtime/agent_loop.hpp"
#include "swarmloc/runtime/process_cpu.hpp"
#include "swarmloc/runtime/sample_log.hpp"

namespace swarmloc::agent {
namespace {

std::atomic<bool> g_stop_requested{false};

// Only sets a flag: never call DDS from a signal handler (docs/style.md, Cyclone section).
void on_signal(int /*signal*/) { g_stop_requested.store(true); }

using runtime::process_cpu_s;

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

/// Monotonic seconds: the clock the agent loop runs on.
double mono_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// One agent process: the agent loop (runtime/agent_loop.hpp) on this process's clock and DDS topics,
/// plus what only a process has: the start-up handshake with the orchestrator, its control commands,
/// signals, the sample log and the logs.
class AgentProcess {
 public:
  AgentProcess(const config::Scenario& scenario, const runtime::AgentManifest& manifest,
               const AgentOptions& options, std::shared_ptr<spdlog::logger> logger)
      : scenario_(scenario),
        options_(options),
        id_(manifest.id),
        logger_(std::move(logger)),
        transport_(scenario, dds::Topology{manifest.id, manifest.agent_count, manifest.neighbours}),
        port_(transport_, *logger_),
        loop_(runtime::make_agent_runtime(scenario, manifest, options.incarnation),
              runtime::loop_settings(scenario, manifest, options.hostile), port_),
        neighbour_count_(static_cast<int>(manifest.neighbours.size())),
        started_(mono_s()) {
    if (!options.record_path.empty()) {
      sample_log_ = std::make_unique<runtime::SampleLogWriter>(options.record_path, manifest.agent_count,
                                                               config::scenario_hash(scenario));
    }
  }

  int run() {
    const runtime::LoopSettings& settings = loop_.settings();
    // Lockstep publishes its initial sample exactly once, when every neighbour can receive it, so that
    // sample numbers (and with them the seeded loss decisions) match the simulator's.
    if (!settings.lockstep) loop_.announce(mono_s());
    logger_->info("started: {} neighbours, clock offset {:+.3f} s drift {:+.1f} ppm{}{}", neighbour_count_,
                  settings.clock.offset_s, settings.clock.drift_ppm,
                  settings.sensor_only ? " (sensor only: the fusion centre estimates)" : "",
                  settings.lockstep ? " (lockstep: steps on each world step's batch)" : "");
    last_hello_s_ = mono_s() - 10.0;
    last_announcement_s_ = mono_s();
    while (!g_stop_requested.load()) {
      // Before START nothing is due sooner than the next hello (START itself wakes the wait); after it,
      // the loop's next tick (lockstep: the next batch wakes it).
      const double wait_s = loop_.started() ? std::clamp(loop_.next_due_s() - mono_s(), 0.0, 0.1) : 0.25;
      auto inbound = transport_.wait_and_take(wait_s);
      const Verdict verdict = handle(inbound);
      if (verdict == Verdict::kRefused) return 2;
      if (verdict == Verdict::kStop) break;
      const double now_s = mono_s();
      log_matched();
      if (!loop_.started()) {
        if (!await_start(now_s)) return 1;
        continue;
      }
      loop_.set_cpu_s(run_cpu_s());
      loop_.advance(now_s);
      if (loop_.orchestrator_silent(now_s)) {
        logger_->warn("no measurements for {:.1f} s: orchestrator gone, exiting", loop_.silent_for_s(now_s));
        break;
      }
    }
    finish();
    return 0;
  }

 private:
  enum class Verdict { kContinue, kStop, kRefused };

  void log_matched() {
    // Logged from launch on: with DDS Security a participant that fails authentication never matches.
    const int matched = transport_.matched_neighbours();
    if (matched != last_matched_) {
      logger_->info("matched {}/{} neighbours", matched, neighbour_count_);
      last_matched_ = matched;
    }
  }

  /// Before START: gets the initial state to the neighbours and says hello. False when START did not
  /// come within the start-up timeout (logged).
  bool await_start(double now_s) {
    const runtime::LoopSettings& settings = loop_.settings();
    if (settings.lockstep && !initial_published_ && transport_.neighbours_matched_both_ways()) {
      loop_.announce(now_s);
      port_.flush();
      initial_published_ = true;
    }
    // Until START: announce the initial state whenever another neighbour's reader has matched
    // (best-effort samples written before that are lost to it), and every 5 s as a backstop. Each
    // announcement goes to every neighbour: at 5 Hz they kept 2 cores busy at N = 500 (docs/scale.md,
    // "Less chatter before START").
    if (!settings.lockstep) {
      const int readers = transport_.matched_neighbour_readers();
      if (readers > announced_to_ || now_s - last_announcement_s_ > 5.0) {
        announced_to_ = std::max(announced_to_, readers);
        last_announcement_s_ = now_s;
        loop_.announce(now_s);
      }
    }
    // Say hello so the orchestrator can count us (lockstep: once the initial sample is with every
    // neighbour), but only once START and our measurements can reach us (control and measurement
    // readers matched): with N >= 150 an agent matched the orchestrator's one reader long before its
    // writers, said hello, and the orchestrator sent START to agents not yet listening. Repeated
    // every 0.5 s until the orchestrator's reader has acknowledged it: a hello written before that
    // reader matched ours is lost.
    if (now_s - last_hello_s_ > 0.5 && (!settings.lockstep || initial_published_) &&
        transport_.orchestrator_matched() && !(hello_sent_ && transport_.reports_acknowledged())) {
      last_hello_s_ = now_s;
      hello_sent_ = true;
      port_.report(loop_.report(now_s, 0.0));
    }
    if (now_s - started_ > scenario_.run.startup_timeout_s + 30.0) {
      logger_->error("no START from the orchestrator within {:.0f} s; exiting",
                     scenario_.run.startup_timeout_s + 30.0);
      return false;
    }
    return true;
  }

  /// The last report, the diagnostics, and the sample log closed.
  void finish() {
    port_.report(loop_.report(mono_s(), run_cpu_s()));
    log_diagnostics();
    if (sample_log_) {
      sample_log_->close();
      logger_->info("recorded {} inter-agent samples to {}", sample_log_->count(), options_.record_path);
    }
  }

  /// Feeds inbound samples to the loop; STOP, or a refusal of our scenario, ends the run.
  Verdict handle(const dds::AgentInbound& inbound) {
    const double now_s = mono_s();
    for (const auto& control : inbound.control) {
      if (control.target != kOrchestratorId && control.target != id_) continue;
      const Verdict verdict = on_control(control, now_s);
      if (verdict != Verdict::kContinue) return verdict;
    }
    if (sample_log_) record(inbound);
    for (const auto& [header, batch] : inbound.batches) loop_.on_batch(header, batch, now_s);
    feed_samples(loop_, inbound, now_s);
    return Verdict::kContinue;
  }

  Verdict on_control(const runtime::ControlMessage& control, double now_s) {
    const std::uint64_t results_hash = loop_.settings().results_hash;
    // A refusal names the hash it refuses: a corrected agent restarted under the same id ignores the
    // refusal its predecessor got (control samples are transient-local).
    const bool refused =
        control.command == runtime::ControlCommand::kRefuse && control.scenario_hash == results_hash;
    const bool foreign =
        control.command == runtime::ControlCommand::kStart && control.scenario_hash != results_hash;
    if (refused || foreign) {
      logger_->error(
          "refused by the orchestrator: this agent's scenario (results hash {:016x}) differs from the run's; "
          "start it with the run directory's scenario.yaml and no --set that changes the world, the "
          "algorithm, the network, the clocks or the run",
          results_hash);
      return Verdict::kRefused;
    }
    if (control.command == runtime::ControlCommand::kStart && !loop_.started()) {
      loop_.start(now_s);
      cpu_at_start_ = process_cpu_s();
      transport_.reset_latency();
      logger_->info("CPU before START (start-up and discovery): {:.3f} s", cpu_at_start_);
      logger_->info("START received");
    } else if (control.command == runtime::ControlCommand::kStop) {
      logger_->info("STOP received");
      return Verdict::kStop;
    }
    return Verdict::kContinue;
  }

  /// --record: every inter-agent sample as taken, with its DDS source timestamp and take time.
  void record(const dds::AgentInbound& inbound) {
    auto append = [&](const auto& samples) {
      for (const auto& sample : samples) {
        sample_log_->append(runtime::ReceivedSample{
            id_, loop_.runtime().steps_run(), sample.source_timestamp_ns, sample.taken_ns, sample.well_formed,
            sample.header, runtime::SampleMessage(sample.message)});
      }
    };
    append(inbound.states);
    append(inbound.information);
    append(inbound.consensus);
    append(inbound.beliefs);
    append(inbound.observations);
  }

  /// CPU seconds spent since START: the steady-state cost the scaling figures compare (start-up and
  /// discovery are logged separately).
  double run_cpu_s() const { return loop_.started() ? process_cpu_s() - cpu_at_start_ : 0.0; }

  void log_diagnostics() const {
    const runtime::AgentRuntime& runtime = loop_.runtime();
    std::uint64_t arrived = 0, delivered = 0, dropped = 0, rejected = 0;
    for (const auto& [sender, link] : runtime.links()) {
      arrived += link.arrived;
      delivered += link.delivered;
      dropped += link.dropped_injected;
      rejected += link.rejected;
    }
    logger_->info(
        "stopping after {} steps: arrived {} delivered {} dropped(injected) {} rejected {}; cpu {:.3f} s",
        runtime.steps_run(), arrived, delivered, dropped, rejected, process_cpu_s());
    const dds::LatencySummary latency = transport_.inter_agent_latency();
    if (latency.samples > 0) {
      logger_->info(
          "inter-agent latency (source timestamp to take): p50 {:.1f} us p99 {:.1f} us over {} samples",
          latency.p50_us, latency.p99_us, latency.samples);
    }
    const auto& reasons = runtime.rejected_by_reason();
    for (std::size_t r = 0; r < reasons.size(); ++r) {
      if (reasons[r] > 0)
        logger_->info("rejected {}: {}", runtime::to_string(static_cast<runtime::RejectReason>(r)),
                      reasons[r]);
    }
  }

  const config::Scenario& scenario_;
  const AgentOptions& options_;
  AgentId id_ = 0;
  std::shared_ptr<spdlog::logger> logger_;
  dds::AgentTransport transport_;
  DdsPort port_;
  runtime::AgentLoop loop_;
  int neighbour_count_ = 0;
  bool initial_published_ = false;  ///< lockstep: the initial sample is out
  bool hello_sent_ = false;         ///< before START: a hello was written (repeated until acknowledged)
  int announced_to_ = 0;   ///< free run before START: neighbour readers our last announcement reached
  int last_matched_ = -1;  ///< neighbours matched when last logged
  double last_hello_s_ = 0.0;
  double last_announcement_s_ = 0.0;
  double cpu_at_start_ = 0.0;
  double started_ = 0.0;                                  ///< launch, monotonic seconds
  std::unique_ptr<runtime::SampleLogWriter> sample_log_;  ///< --record
};

}  // namespace

namespace {

/// The scenario and the manifest must describe the same run, and --id (if given) the manifest's agent.
void check_manifest(config::Scenario& scenario, const runtime::AgentManifest& manifest,
                    const AgentOptions& options) {
  if (options.id >= 0 && options.id != manifest.id) {
    throw runtime::ManifestError("--id " + std::to_string(options.id) + " but the manifest is agent " +
                                 std::to_string(manifest.id) + "'s");
  }
  if (config::results_hash(scenario) != manifest.results_hash) {
    throw runtime::ManifestError(
        "the manifest was written for another scenario (results hash differs): start the agent with the run "
        "directory's scenario.yaml and no --set that changes the world, the algorithm, the network, the "
        "clocks or the run");
  }
  if (scenario.dds.run_id.empty()) scenario.dds.run_id = manifest.run_id;  // the manifest names the run
  if (scenario.dds.run_id != manifest.run_id) {
    throw runtime::ManifestError("dds.run_id " + scenario.dds.run_id + " but the manifest belongs to run " +
                                 manifest.run_id);
  }
  if (!scenario.dds.security_dir.empty()) dds::security_files(scenario.dds.security_dir, manifest.id);
}

/// The scenario and manifest, checked; nullopt (logged) on bad input.
std::optional<std::pair<config::Scenario, runtime::AgentManifest>> load_inputs(
    const AgentOptions& options, const ManifestSource& manifest_source, spdlog::logger& logger) {
  try {
    // Without --scenario the defaults and --set tell where to wait for the manifest sample.
    config::Scenario scenario = options.scenario_path.empty()
                                    ? config::parse_scenario("{}", options.overrides, "--set")
                                    : config::load_scenario(options.scenario_path, options.overrides);
    runtime::AgentManifest manifest = manifest_source(scenario, options);
    check_manifest(scenario, manifest, options);
    return std::make_pair(std::move(scenario), std::move(manifest));
  } catch (const config::ScenarioError& error) {
    logger.error("{}", error.what());
  } catch (const runtime::ManifestError& error) {
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
  std::optional<std::pair<config::Scenario, runtime::AgentManifest>> inputs;
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
