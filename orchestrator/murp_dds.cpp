// A MURP trial over DDS in lockstep (murp_dds.hpp; docs/real-data.md, "MURP over DDS"): one agent process
// per vehicle; each window goes out only when every vehicle has reported the previous one, so the vehicles
// run exactly the rounds of the in-process runner and report the same estimates.
#include "murp_dds.hpp"

#include <chrono>
#include <cstdio>
#include <exception>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "agent_launch.hpp"
#include "console.hpp"
#include "launcher.hpp"
#include "swarmloc/dds/transport.hpp"
#include "swarmloc/dds/uwb_team_io.hpp"

namespace swarmloc::orchestrator {
namespace {

namespace uwb = estimators::uwb;

constexpr double kMatchTimeoutS = 30.0;  ///< agents' start-up and discovery
constexpr double kExitTimeoutS = 10.0;   ///< from stop to every agent's exit
constexpr double kPollS = 0.05;          ///< longest wait between two looks at the agents' processes

/// Every vehicle with sensing or ranges in some window: one agent process each.
std::vector<AgentId> murp_team(const std::vector<world::MurpTeamWindow>& windows) {
  std::set<AgentId> team;
  for (const auto& window : windows) {
    for (const auto& [vehicle, sensing] : window.sensing) team.insert(vehicle);
    for (const auto& [vehicle, ranges] : window.ranges) team.insert(vehicle);
  }
  return {team.begin(), team.end()};
}

std::string seconds_text(double seconds) {
  char text[32];
  std::snprintf(text, sizeof text, "%g s", seconds);
  return text;
}

std::string comma_list(const std::vector<AgentId>& team) {
  std::string text;
  for (const AgentId vehicle : team) text += (text.empty() ? "" : ",") + std::to_string(vehicle);
  return text;
}

dds::UwbWindowInput window_input(const world::MurpTeamWindow& window, AgentId vehicle) {
  dds::UwbWindowInput input{vehicle, window.index, window.time_s, window.dt_s, false, std::nullopt, {}};
  if (const auto sensing = window.sensing.find(vehicle); sensing != window.sensing.end())
    input.sensing = sensing->second;
  if (const auto ranges = window.ranges.find(vehicle); ranges != window.ranges.end())
    input.ranges = ranges->second;
  return input;
}

nlohmann::json counters_json(const dds::UwbTeamCounters& counters, bool ros2) {
  nlohmann::json json{{"samples_sent", counters.sent},
                      {"write_timeouts", counters.write_timeouts},
                      {"samples_received", counters.received},
                      {"samples_rejected", counters.rejected},
                      {"rejected_by_reason", counters.rejected_by_reason}};
  if (ros2) {
    json["ros2_samples_sent"] = counters.ros2_sent;
    json["ros2_write_timeouts"] = counters.ros2_write_timeouts;
  }
  return json;
}

class MurpDdsDriver {
 public:
  MurpDdsDriver(const std::vector<world::MurpTeamWindow>& windows, const MurpDdsOptions& options)
      : windows_(windows),
        options_(options),
        team_(murp_team(windows)),
        io_(dds::UwbTeamEndpoint{options.domain_id, team_, kOrchestratorId}, options.ros2) {}

  MurpDdsRun run() {
    launch();
    const auto started = Clock::now();
    const bool team_ready = wait_for_team();
    if (team_ready) match_s_ = seconds_since(started);
    if (team_ready && wait_for_ros2_subscribers()) {
      Progress progress(options_.progress);
      for (const auto& window : windows_) {
        if (!run_window(window)) break;
        if ((window.index + 1) % 10 == 0 || window.index + 1 == static_cast<std::int64_t>(windows_.size())) {
          progress.update(progress_text(window.index, started));
        }
      }
      progress.finish();
    }
    stop();
    result_.counters["dds"] = counters();
    return std::move(result_);
  }

 private:
  void launch() {
    const auto agents_dir = options_.run_dir / "agents";
    std::filesystem::create_directories(agents_dir);
    for (const AgentId vehicle : team_) {
      const auto log = agents_dir / ("vehicle_" + std::to_string(vehicle));
      auto argv = agent_executable(options_.agent_binary);
      argv.insert(argv.end(), {"--uwb-team", options_.calibration_path.string(), "--vehicle",
                               std::to_string(vehicle), "--team", comma_list(team_), "--domain",
                               std::to_string(options_.domain_id), "--log", log.string() + ".log"});
      if (!options_.cooperate) argv.emplace_back("--no-cooperation");
      launcher_.launch(argv, log.string() + ".out");
    }
  }

  /// Until every vehicle has said hello (its endpoints are matched both ways) and ours are matched.
  bool wait_for_team() {
    std::set<AgentId> ready;
    const auto deadline = Clock::now() + std::chrono::duration<double>(kMatchTimeoutS);
    while (ready.size() < team_.size() || !io_.matched()) {
      if (!alive()) return false;
      if (Clock::now() > deadline) {
        return fail("the vehicles' agents did not all connect within " + seconds_text(kMatchTimeoutS) +
                    " (their logs: " + (options_.run_dir / "agents").string() + ")");
      }
      for (const auto& estimates : io_.wait_and_take_estimates(kPollS)) {
        if (estimates.round == dds::UwbRound::kHello) ready.insert(estimates.vehicle);
      }
    }
    return true;
  }

  /// With --ros2-subscribers N: until N ROS 2 readers (per subscriber and topic) have matched our writers.
  bool wait_for_ros2_subscribers() {
    if (!options_.ros2 || options_.ros2_subscribers <= 0) return true;
    const auto deadline = Clock::now() + std::chrono::duration<double>(kMatchTimeoutS);
    while (io_.ros2_matched_readers() < options_.ros2_subscribers) {
      if (!alive()) return false;
      if (Clock::now() > deadline) {
        return fail("--ros2-subscribers " + std::to_string(options_.ros2_subscribers) + ": " +
                    std::to_string(io_.ros2_matched_readers()) +
                    " ROS 2 readers had matched the rt/swarmloc/murp/ topics after " +
                    seconds_text(kMatchTimeoutS) + " (docs/ros2.md, \"MURP relative poses\")");
      }
      io_.wait_and_take_estimates(kPollS);  // only hellos until the first window
    }
    return true;
  }

  /// Window k's reports and truth on ROS 2, each peer with its IMU's tilt (its last one if it has none in
  /// this window, as its observers' filters use it).
  void publish_ros2(const world::MurpTeamWindow& window,
                    const std::map<AgentId, std::map<AgentId, uwb::PoseEstimate>>& reports) {
    for (const auto& [vehicle, sensing] : window.sensing) last_tilt_[vehicle] = sensing.tilt;
    if (!options_.ros2) return;
    dds::UwbRos2Window ros2{window.time_s, last_tilt_, {}, window.truth};
    for (const auto& [observer, peers] : reports) {
      for (const auto& [peer, estimate] : peers) ros2.estimates[{observer, peer}] = estimate;
    }
    io_.publish_ros2_window(ros2);
  }

  /// Sends window k to every vehicle and collects every vehicle's fused estimates of it as rows.
  bool run_window(const world::MurpTeamWindow& window) {
    for (const AgentId vehicle : team_) io_.publish_window(window_input(window, vehicle));
    std::map<AgentId, std::map<AgentId, uwb::PoseEstimate>> reports;
    const auto deadline = Clock::now() + std::chrono::duration<double>(options_.window_timeout_s);
    while (reports.size() < team_.size()) {
      if (!alive()) return false;
      if (Clock::now() > deadline) {
        ++window_timeouts_;
        return fail("window " + std::to_string(window.index) + ": not every vehicle reported within " +
                    seconds_text(options_.window_timeout_s));
      }
      for (auto& estimates : io_.wait_and_take_estimates(kPollS)) {
        if (estimates.round != dds::UwbRound::kFused) continue;
        if (estimates.window == window.index) {
          reports[estimates.vehicle] = std::move(estimates.peers);
        } else {
          ++stale_reports_;  // a report of another window: not this one's
        }
      }
    }
    for (const auto& [vehicle, peers] : reports) {
      for (const auto& [peer, estimate] : peers)
        result_.rows.push_back({window.index, vehicle, peer, estimate});
    }
    publish_ros2(window, reports);
    ++windows_completed_;
    return true;
  }

  /// False (and the run failed) once an agent has exited or the run was interrupted.
  bool alive() {
    if (interrupted().load()) return fail("interrupted");
    launcher_.poll();
    for (int index = 0; index < launcher_.size(); ++index) {
      if (launcher_.running(index)) continue;
      const AgentId vehicle = team_[static_cast<std::size_t>(index)];
      return fail(
          "vehicle " + std::to_string(vehicle) + "'s agent exited with code " +
          std::to_string(launcher_.exit_code(index).value_or(-1)) + " before the end of the run (log: " +
          (options_.run_dir / "agents" / ("vehicle_" + std::to_string(vehicle) + ".log")).string() + ")");
    }
    return true;
  }

  /// Stop to every vehicle, a bounded wait for their exits, then the launcher's SIGTERM/SIGKILL.
  void stop() {
    for (const AgentId vehicle : team_) {
      io_.publish_window(dds::UwbWindowInput{vehicle, 0, 0.0, 0.0, true, std::nullopt, {}});
    }
    const auto deadline = Clock::now() + std::chrono::duration<double>(kExitTimeoutS);
    while (launcher_.poll() > 0 && Clock::now() < deadline) io_.wait_and_take_estimates(kPollS);
    launcher_.stop_all(2.0);
    for (int index = 0; index < launcher_.size(); ++index) {
      const int code = launcher_.exit_code(index).value_or(-1);
      const AgentId vehicle = team_[static_cast<std::size_t>(index)];
      exit_codes_[std::to_string(vehicle)] = code;
      if (code != 0)
        fail("vehicle " + std::to_string(vehicle) + "'s agent exited with code " + std::to_string(code));
    }
  }

  nlohmann::json counters() const {
    nlohmann::json counters = counters_json(io_.counters(), options_.ros2);
    counters.update({{"domain_id", options_.domain_id},
                     {"windows_completed", windows_completed_},
                     {"window_timeouts", window_timeouts_},
                     {"stale_reports", stale_reports_},
                     {"match_s", match_s_},
                     {"agent_exit_codes", exit_codes_}});
    return counters;
  }

  std::string progress_text(std::int64_t index, Clock::time_point started) const {
    char line[96];
    std::snprintf(line, sizeof line, "[%6.1fs] window %lld/%zu: %zu vehicles over DDS",
                  seconds_since(started), static_cast<long long>(index) + 1, windows_.size(), team_.size());
    return line;
  }

  /// Records the first failure; always false (for `return fail(...)`).
  bool fail(const std::string& why) {
    if (!result_.failed) {
      result_.failed = true;
      result_.failure = why;
    }
    return false;
  }

  const std::vector<world::MurpTeamWindow>& windows_;
  MurpDdsOptions options_;
  std::vector<AgentId> team_;
  dds::UwbOrchestratorIo io_;
  ProcessLauncher launcher_;  // declared after io_: destroyed (children killed) before the participant
  MurpDdsRun result_;
  std::map<AgentId, uwb::Tilt> last_tilt_;  ///< each vehicle's newest IMU tilt (ROS 2 orientations)
  std::int64_t windows_completed_ = 0;
  int window_timeouts_ = 0;
  std::uint64_t stale_reports_ = 0;
  double match_s_ = 0.0;  ///< launch to the first window
  nlohmann::json exit_codes_ = nlohmann::json::object();
};

/// The domain's fixed ports must be clear of the ephemeral range and free (another run on the same domain).
void require_domain_usable(int domain_id, int team_size) {
  const auto scenario = dds::uwb_team_scenario(domain_id, team_size);
  dds::require_ports_fit(scenario);
  dds::require_ports_clear_of(scenario, dds::ephemeral_port_range());
  dds::require_ports_free(scenario, true);
}

}  // namespace

MurpDdsRun run_murp_over_dds(const std::vector<world::MurpTeamWindow>& windows,
                             const MurpDdsOptions& options) {
  install_interrupt_handlers();
  try {
    require_domain_usable(options.domain_id, static_cast<int>(murp_team(windows).size()));
  } catch (const std::exception& error) {
    return MurpDdsRun{{}, nlohmann::json::object(), true, true, error.what()};
  }
  try {
    MurpDdsDriver driver(windows, options);
    return driver.run();
  } catch (const std::exception& error) {  // no participant, a team beyond the IDL's bounds
    return MurpDdsRun{{}, nlohmann::json::object(), true, false, error.what()};
  }
}

}  // namespace swarmloc::orchestrator
