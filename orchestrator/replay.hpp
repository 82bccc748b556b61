#pragma once
// `swarmloc replay FILE`: feeds a recording's measurements (recording.slrec, written by `run --record`
// or `sim --record`) to fresh agents — in the simulator, or with --dds over DDS agent processes — so
// algorithms can be compared on identical input (docs/record-replay.md).
#include <filesystem>
#include <string>
#include <vector>

namespace swarmloc::orchestrator {

struct ReplayOptions {
  /// The recording to replay. (A second source, `--mrclam DIR`, is planned: it will supply the
  /// scenario and the RecordedSteps the same way, see replay.cpp.)
  std::string recording_path;
  bool dds = false;                    ///< over DDS agent processes (default: the simulator)
  std::vector<std::string> overrides;  ///< --set on the recorded scenario (no world.* or seed)
  std::filesystem::path out_dir;       ///< empty: runs/<name>-<stamp>-seed<seed>
  bool progress = true;
  bool record = false;       ///< record the replay too (e.g. the inter-agent samples of another algorithm)
  std::string agent_binary;  ///< --dds: the swarmloc executable used to start agents
};

/// Returns the process exit code (0 ok, 2 bad input: unreadable recording, rejected override, more
/// steps than recorded; 1 runtime failure or interrupted).
int run_replay(const ReplayOptions& options);

}  // namespace swarmloc::orchestrator
