#pragma once
// A MURP trial over DDS (docs/real-data.md, "MURP"): one `swarmloc agent --uwb-team` process per vehicle, fed
// window by window in lockstep by the orchestrator, the vehicles exchanging their IMU readings and their
// estimates of each other on DDS topics.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "swarmloc/world/murp_team.hpp"

namespace swarmloc::orchestrator {

struct MurpDdsOptions {
  std::string agent_binary;                ///< the swarmloc executable the agents run
  std::filesystem::path run_dir;           ///< agents' logs go to run_dir/agents/
  std::filesystem::path calibration_path;  ///< the range model file every agent reads
  bool cooperate = true;
  int domain_id = 0;
  bool progress = true;
  double window_timeout_s = 20.0;  ///< longest wait for every vehicle's estimates of one window
  /// Also publish every window's relative poses and their truth on ROS 2 topics (docs/ros2.md, "MURP
  /// relative poses").
  bool ros2 = false;
  /// With ros2: before the first window, wait (at most 30 s) until this many ROS 2 readers have matched
  /// those topics, counted once per subscriber and topic (subscribers started before the run); 0: no wait.
  int ros2_subscribers = 0;
};

struct MurpDdsRun {
  std::vector<world::RelativeEstimateRow> rows;
  nlohmann::json counters = nlohmann::json::object();  ///< samples sent, received, rejected; timeouts
  bool failed = false;  ///< an agent died, a window timed out, or the run was interrupted
  /// The run never started for want of a usable domain (ports in the ephemeral range or taken): exit 2.
  bool bad_input = false;
  std::string failure;
};

MurpDdsRun run_murp_over_dds(const std::vector<world::MurpTeamWindow>& windows,
                             const MurpDdsOptions& options);

}  // namespace swarmloc::orchestrator
