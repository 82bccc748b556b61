#pragma once
// `swarmloc replay --murp TRIAL_DIR`: a MURP UWB trial (three vehicles ranging between their antennas)
// replayed to one agent process per vehicle over DDS, or in process with --sim; each vehicle estimates the
// others' relative poses (docs/real-data.md, "MURP").
#include <filesystem>
#include <string>

namespace swarmloc::orchestrator {

struct MurpReplayOptions {
  std::string trial_dir;
  /// The range calibration (`swarmloc calibrate --murp --out`); empty: the one built in, fitted on trials
  /// 01–12 (scenarios/murp-range-bias.json).
  std::string bias_path;
  bool no_bias = false;           ///< --no-bias: no bias correction (and the default noise model)
  bool cooperate = true;          ///< --no-cooperation: each vehicle on its own ranges only
  bool in_process = false;        ///< --sim
  std::filesystem::path out_dir;  ///< empty: runs/murp-<trial>-<stamp>
  bool force = false;
  bool progress = true;
  std::string agent_binary;  ///< DDS: the swarmloc executable that agents run
  int domain_id = 0;         ///< DDS domain
  /// --ros2: the orchestrator also publishes the relative poses and their truth on ROS 2 topics (DDS only;
  /// docs/ros2.md, "MURP relative poses").
  bool ros2 = false;
  int ros2_subscribers = 0;  ///< --ros2-subscribers: ROS 2 readers (per topic) to wait for before window 0
};

/// Returns the process exit code: 0 ok; 1 runtime failure (an agent died or the run was interrupted);
/// 2 bad input (an unreadable trial or calibration file, an unusable --out).
int run_murp_replay(const MurpReplayOptions& options);

}  // namespace swarmloc::orchestrator
