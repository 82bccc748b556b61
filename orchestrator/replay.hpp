#pragma once
// `swarmloc replay FILE`: feeds a recording's measurements (recording.slrec, written by `run --record`
// or `sim --record`) to fresh agents — in the simulator, or with --dds over DDS agent processes — so
// algorithms can be compared on identical input (docs/record-replay.md).
#include <filesystem>
#include <string>
#include <vector>

namespace swarmloc::orchestrator {

struct ReplayOptions {
  /// The recording to replay, or (mrclam_dir) a UTIAS MRCLAM dataset directory.
  std::string recording_path;
  std::string mrclam_dir;   ///< --mrclam DIR: five robots as five agents (DDS unless in_process)
  double speedup = 10.0;    ///< --mrclam: dataset seconds per wall-clock second (free run)
  bool in_process = false;  ///< --mrclam --sim: the in-process simulator instead of DDS
  /// --mrclam --noise FILE: the noise model to replay with, a `noise:` block as `swarmloc calibrate --out`
  /// writes it. Empty: the dataset's own noise, measured from its groundtruth as calibrate does.
  std::string noise_path;
  bool dds = false;                    ///< over DDS agent processes (default: the simulator)
  std::vector<std::string> overrides;  ///< --set on the recorded scenario (no world.* or seed)
  std::filesystem::path out_dir;       ///< empty: runs/<name>-<stamp>-seed<seed>
  bool force = false;                  ///< --force: a non-empty out_dir holding an earlier run is cleared
  bool progress = true;
  bool record = false;       ///< record the replay too (e.g. the inter-agent samples of another algorithm)
  std::string agent_binary;  ///< --dds: the swarmloc executable used to start agents
};

/// Returns the process exit code (0 ok, 2 bad input: unreadable recording, rejected override, more
/// steps than recorded; 1 runtime failure or interrupted).
int run_replay(const ReplayOptions& options);

}  // namespace swarmloc::orchestrator
