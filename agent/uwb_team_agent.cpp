#include "uwb_team_agent.hpp"

#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/dds/uwb_team_io.hpp"
#include "swarmloc/runtime/range_calibration_file.hpp"
#include "uwb_team_rounds.hpp"

namespace swarmloc::agent {
namespace {

namespace uwb = estimators::uwb;

std::atomic<bool> g_uwb_stop{false};

// Only sets a flag: never call DDS from a signal handler (docs/style.md, Cyclone section).
void on_uwb_signal(int /*signal*/) { g_uwb_stop.store(true); }

double uwb_now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::shared_ptr<spdlog::logger> uwb_logger(const UwbTeamAgentOptions& options) {
  const std::string name = "vehicle" + std::to_string(options.vehicle);
  auto logger = options.log_path.empty() ? spdlog::stderr_color_mt(name)
                                         : spdlog::basic_logger_mt(name, options.log_path, true);
  logger->set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ [" + name + "] %v");
  logger->flush_on(spdlog::level::info);
  return logger;
}

/// The command line's problem, or empty.
std::string argument_problem(const UwbTeamAgentOptions& options) {
  auto team = options.team;
  std::sort(team.begin(), team.end());
  if (team.size() < 2 || team.size() > 8 || std::adjacent_find(team.begin(), team.end()) != team.end() ||
      team.front() < 0) {
    return "--team needs 2-8 distinct non-negative vehicle ids";
  }
  if (!std::binary_search(team.begin(), team.end(), options.vehicle)) return "--vehicle is not on --team";
  if (options.calibration_path.empty()) return "--uwb-team needs the range calibration file";
  return {};
}

/// This vehicle's range model of each teammate, from the calibration file; nullopt (logged) on bad input.
std::optional<std::map<AgentId, uwb::RelativePoseParams>> load_models(const UwbTeamAgentOptions& options,
                                                                      spdlog::logger& logger) {
  try {
    const auto calibration = runtime::read_range_calibration(options.calibration_path);
    std::map<AgentId, uwb::RelativePoseParams> models;
    for (const AgentId teammate : options.team) {
      if (teammate != options.vehicle)
        models.emplace(teammate, uwb::range_model(calibration, options.vehicle, teammate));
    }
    return models;
  } catch (const config::ScenarioError& error) {
    logger.error("{}", error.what());
  } catch (const std::out_of_range&) {
    logger.error("{}: no entry for vehicle {} or one of its teammates", options.calibration_path,
                 options.vehicle);
  }
  return std::nullopt;
}

/// Robustness tests: SWARMLOC_UWB_FAULT="<vehicle>:<window>" makes that vehicle die by SIGKILL, as a crash
/// would, once it has reported that window (so its teammates and the orchestrator lose it mid-run).
std::optional<std::int64_t> fault_window(AgentId vehicle) {
  const char* fault = std::getenv("SWARMLOC_UWB_FAULT");
  long long at_vehicle = -1;
  long long at_window = -1;
  if (fault == nullptr || std::sscanf(fault, "%lld:%lld", &at_vehicle, &at_window) != 2) return std::nullopt;
  return at_vehicle == vehicle ? std::optional<std::int64_t>(at_window) : std::nullopt;
}

void log_counters(spdlog::logger& logger, const UwbTeamRounds& rounds, const dds::UwbTeamCounters& io) {
  const auto& c = rounds.counters();
  logger.info(
      "windows {}, samples sent {} (write timeouts {}), received {}, ignored {}, rejected {}; missing "
      "sensing {}, missing estimates {}, late {}",
      c.windows, io.sent, io.write_timeouts, io.received, io.ignored, io.rejected, c.missing_sensing,
      c.missing_estimates, c.late_samples);
  for (const auto& [reason, count] : io.rejected_by_reason)
    logger.warn("rejected {} samples: {}", count, reason);
}

/// The process's loop: hellos until the first window input, then the rounds until stop.
int serve(const UwbTeamAgentOptions& options, std::map<AgentId, uwb::RelativePoseParams> models,
          spdlog::logger& logger) {
  dds::UwbVehicleIo io(dds::UwbTeamEndpoint{options.domain_id, options.team, options.vehicle});
  UwbTeamRounds rounds(uwb::TeamMember(options.vehicle, std::move(models)), options.team, options.cooperate,
                       options.round_timeout_s,
                       {[&io](const dds::UwbSensing& sensing) { io.publish_sensing(sensing); },
                        [&io](const dds::UwbEstimates& estimates) { io.publish_estimates(estimates); }});
  constexpr double kHelloPeriodS = 0.5;  // until the orchestrator's first input shows it heard one
  bool started = false;
  double last_input_s = uwb_now_s();
  double next_hello_s = last_input_s;
  std::int64_t logged = -1;
  const auto fault = fault_window(options.vehicle);
  while (!g_uwb_stop.load()) {
    const auto inbound = io.wait_and_take(0.1);
    const double now = uwb_now_s();
    if (!inbound.inputs.empty()) {
      started = true;
      last_input_s = now;
    }
    if (!started && now >= next_hello_s && io.matched_both_ways()) {
      io.publish_estimates({options.vehicle, -1, dds::UwbRound::kHello, {}});
      next_hello_s = now + kHelloPeriodS;
    }
    rounds.take(inbound);
    rounds.advance(now);
    if (rounds.windows_done() > logged && (logged < 0 || rounds.windows_done() >= logged + 50)) {
      logged = rounds.windows_done();
      logger.info("window {} done", logged);
    }
    if (fault && rounds.windows_done() >= *fault) {
      logger.warn("SWARMLOC_UWB_FAULT: dying after window {}", rounds.windows_done());
      std::raise(SIGKILL);
    }
    if (rounds.stopped()) break;
    if (now - last_input_s > options.idle_timeout_s) {
      logger.error("no window input for {} s: the orchestrator is gone", options.idle_timeout_s);
      log_counters(logger, rounds, io.counters());
      return 1;
    }
  }
  logger.info(rounds.stopped() ? "stopped by the orchestrator" : "stopped by a signal");
  log_counters(logger, rounds, io.counters());
  return 0;
}

}  // namespace

int run_uwb_team_agent(const UwbTeamAgentOptions& options) {
  std::signal(SIGINT, on_uwb_signal);
  std::signal(SIGTERM, on_uwb_signal);
  std::signal(SIGHUP, on_uwb_signal);
  std::signal(SIGPIPE, SIG_IGN);
  std::shared_ptr<spdlog::logger> logger;
  try {
    logger = uwb_logger(options);
  } catch (const spdlog::spdlog_ex& error) {
    std::fprintf(stderr, "error: --log %s: %s\n", options.log_path.c_str(), error.what());
    return 2;
  }
  if (const auto problem = argument_problem(options); !problem.empty()) {
    logger->error("{}", problem);
    return 2;
  }
  auto models = load_models(options, *logger);
  if (!models) return 2;
  try {
    return serve(options, std::move(*models), *logger);
  } catch (const std::exception& error) {
    logger->error("runtime failure: {}", error.what());
    return 1;
  }
}

}  // namespace swarmloc::agent
