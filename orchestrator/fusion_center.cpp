#include "fusion_center.hpp"

#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <map>
#include <optional>

#include "swarmloc/dds/transport.hpp"
#include "swarmloc/run/fusion_centre.hpp"
#include "swarmloc/runtime/process_cpu.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::orchestrator {
namespace {

using Clock = std::chrono::steady_clock;

std::atomic<bool> g_stop_requested{false};

// Only sets a flag: never call DDS from a signal handler.
void on_stop_signal(int /*signal*/) { g_stop_requested.store(true); }

using runtime::process_cpu_s;

std::shared_ptr<spdlog::logger> make_logger(const FusionOptions& options) {
  const std::string name = "fusion";
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

std::int64_t stamp_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
}

class FusionProcess {
 public:
  FusionProcess(const config::Scenario& scenario, const world::World& world,
                std::shared_ptr<spdlog::logger> logger)
      : scenario_(scenario),
        agent_count_(world.size()),
        logger_(std::move(logger)),
        filter_(run::make_fusion_filter(scenario, world)),
        transport_(scenario, world.size()),
        period_s_(1.0 / scenario.run.rate_hz),
        started_(Clock::now()),
        results_hash_(config::results_hash(scenario)) {}

  int run() {
    logger_->info("started: {} for {} agents in {}-D, L = {}", filter_->name(), agent_count_,
                  filter_->dimension(), run::centralized_bandwidth(filter_->dimension()));
    auto last_hello = Clock::now() - std::chrono::seconds(10);
    auto last_batch_seen = Clock::now();
    bool matched_logged = false;
    while (!g_stop_requested.load()) {
      const auto inbound = transport_.wait_and_take(std::min(0.05, period_s_ / 4.0));
      const Verdict verdict = handle_control(inbound);
      if (verdict == Verdict::kRefused) return 2;
      if (verdict == Verdict::kStop) break;
      const auto now = Clock::now();
      if (!inbound.batches.empty()) last_batch_seen = now;
      for (const auto& batch : inbound.batches) store(batch, now);
      if (!matched_logged && transport_.orchestrator_matched()) {
        logger_->info("matched the orchestrator's {} measurement writers after {:.2f} s", agent_count_,
                      std::chrono::duration<double>(now - started_).count());
        matched_logged = true;
      }
      if (!started_run_) {
        // Until START: say hello so the orchestrator knows the fusion centre is up.
        if (now - last_hello > std::chrono::milliseconds(200)) {
          last_hello = now;
          runtime::EstimateReport hello;
          hello.header = runtime::Header{dds::kFusionCenterId, 0, 0, stamp_ns(), 0};
          hello.cpu_s = process_cpu_s();
          hello.results_hash = results_hash_;
          transport_.publish_estimate(hello);
        }
        const double limit_s = scenario_.run.startup_timeout_s + 30.0;
        if (std::chrono::duration<double>(now - started_).count() > limit_s) {
          logger_->error("no START from the orchestrator within {:.0f} s; exiting", limit_s);
          return 1;
        }
        last_batch_seen = now;
        continue;
      }
      step_ready(now);
      const double silent_s = std::chrono::duration<double>(now - last_batch_seen).count();
      if (silent_s > std::max(5.0, 50.0 * period_s_)) {
        logger_->warn("no measurements for {:.1f} s: orchestrator gone, exiting", silent_s);
        break;
      }
    }
    logger_->info(
        "stopping after {} steps ({} with missing batches, {} late batches dropped, {} malformed); cpu "
        "{:.3f} s",
        filter_->steps_done(), incomplete_steps_, late_batches_, transport_.dropped_malformed(),
        process_cpu_s());
    return 0;
  }

 private:
  struct PendingStep {
    std::vector<std::optional<estimators::MeasurementBatch>> batches;
    int count = 0;
    Clock::time_point first_seen;
    double world_time_s = 0.0;
  };

  enum class Verdict { kContinue, kStop, kRefused };

  /// STOP, or a refusal of our scenario (as for an agent, agent_node.cpp), ends the run.
  Verdict handle_control(const dds::FusionInbound& inbound) {
    for (const auto& control : inbound.control) {
      const bool refused = control.command == runtime::ControlCommand::kRefuse &&
                           control.target == dds::kFusionCenterId && control.scenario_hash == results_hash_;
      const bool foreign =
          control.command == runtime::ControlCommand::kStart && control.scenario_hash != results_hash_;
      if (refused || foreign) {
        logger_->error(
            "refused by the orchestrator: this fusion centre's scenario (results hash {:016x}) differs from "
            "the run's; start it with the run directory's scenario.yaml",
            results_hash_);
        return Verdict::kRefused;
      }
      if (control.command == runtime::ControlCommand::kStart && !started_run_) {
        started_run_ = true;
        logger_->info("START received");
      } else if (control.command == runtime::ControlCommand::kStop) {
        logger_->info("STOP received");
        return Verdict::kStop;
      }
    }
    return Verdict::kContinue;
  }

  void store(const dds::FusionBatch& in, Clock::time_point now) {
    const std::int64_t step = in.batch.world_step;
    if (step < next_step_) {
      ++late_batches_;  // docs/algorithms.md §2.7: a measurement older than the current step is discarded
      return;
    }
    auto [it, inserted] = pending_.try_emplace(step);
    auto& pending = it->second;
    if (inserted) {
      pending.batches.resize(static_cast<std::size_t>(agent_count_));
      pending.first_seen = now;
      pending.world_time_s = in.batch.world_time_s;
    }
    auto& slot = pending.batches[static_cast<std::size_t>(in.agent)];
    if (slot) return;  // duplicate
    slot = in.batch;
    ++pending.count;
  }

  /// Steps the filter through every world step whose batches are complete, or whose first batch
  /// arrived more than two periods ago (then with what arrived; missing rows are simply left out).
  void step_ready(Clock::time_point now) {
    const auto wait_limit = std::chrono::duration<double>(2.0 * period_s_);
    while (!pending_.empty()) {
      auto it = pending_.begin();
      const std::int64_t step = it->first;
      auto& pending = it->second;
      const bool complete = pending.count == agent_count_;
      if (!complete && now - pending.first_seen < wait_limit) break;
      if (!complete) {
        ++incomplete_steps_;
        logger_->warn("step {}: {}/{} batches after {:.0f} ms; stepping with what arrived", step,
                      pending.count, agent_count_,
                      1e3 * std::chrono::duration<double>(now - pending.first_seen).count());
      }
      // World steps of which nothing arrived: prediction only.
      while (next_step_ < step) {
        filter_->step(estimators::centralized::CentralizedMeasurements{});
        ++next_step_;
      }
      std::vector<const estimators::MeasurementBatch*> pointers(static_cast<std::size_t>(agent_count_),
                                                                nullptr);
      for (std::size_t i = 0; i < pointers.size(); ++i) {
        if (pending.batches[i]) pointers[i] = &*pending.batches[i];
      }
      filter_->step(run::centralized_measurements(scenario_, pointers));
      ++next_step_;
      publish_estimates(step, pending.world_time_s);
      pending_.erase(it);
    }
  }

  void publish_estimates(std::int64_t step, double world_time_s) {
    const double cpu_s = process_cpu_s();
    const auto world_ns = static_cast<std::int64_t>(std::llround(world_time_s * 1e9));
    for (AgentId i = 0; i < agent_count_; ++i) {
      runtime::EstimateReport report;
      report.header = runtime::Header{i, static_cast<std::uint32_t>(step), step, stamp_ns(), world_ns};
      report.estimate = run::fusion_estimate(*filter_, i);
      report.steps_run = static_cast<std::uint32_t>(next_step_);
      report.samples_published = static_cast<std::uint32_t>(next_step_);
      report.cpu_s = cpu_s;
      report.results_hash = results_hash_;
      transport_.publish_estimate(report);
    }
  }

  const config::Scenario& scenario_;
  int agent_count_;
  std::shared_ptr<spdlog::logger> logger_;
  std::unique_ptr<estimators::centralized::CentralizedFilter> filter_;
  dds::FusionTransport transport_;
  double period_s_;
  Clock::time_point started_;
  bool started_run_ = false;
  std::map<std::int64_t, PendingStep> pending_;
  std::int64_t next_step_ = 0;
  int incomplete_steps_ = 0;
  std::uint64_t late_batches_ = 0;
  std::uint64_t results_hash_;
};

}  // namespace

int run_fusion_center(const FusionOptions& options) {
  std::signal(SIGINT, on_stop_signal);
  std::signal(SIGTERM, on_stop_signal);
  std::signal(SIGHUP, on_stop_signal);
  std::signal(SIGPIPE, SIG_IGN);
  auto logger = make_logger(options);
  config::Scenario scenario;
  world::World world;
  try {
    scenario = config::load_scenario(options.scenario_path, options.overrides);
    world = world::build_world(scenario);
    if (!scenario.dds.security_dir.empty())
      dds::security_files(scenario.dds.security_dir, dds::kFusionCenterId);
  } catch (const config::ScenarioError& error) {
    logger->error("{}", error.what());
    return 2;
  }
  if (!config::runs_in_fusion_centre(scenario.algorithm.name)) {
    logger->error("algorithm.name: '{}' is not a centralized algorithm (ekf, lbekf, lbekf_vr, lbekf_i)",
                  scenario.algorithm.name);
    return 2;
  }
  if (scenario.dds.run_id.empty()) {
    logger->error("dds.run_id is empty: start the fusion centre with the run directory's scenario.yaml");
    return 2;
  }
  try {
    FusionProcess process(scenario, world, logger);
    return process.run();
  } catch (const std::exception& error) {
    logger->error("runtime failure: {}", error.what());
    return 1;
  }
}

}  // namespace swarmloc::orchestrator
