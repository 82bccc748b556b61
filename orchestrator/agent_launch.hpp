#pragma once
// How `swarmloc run` starts the processes of a run: the command line of each agent process (and of its
// restarts after faults.kill) and of the fusion centre, with their logs in the run directory.
#include <filesystem>
#include <string>
#include <vector>

#include "swarmloc/core/types.hpp"

namespace swarmloc::orchestrator {

struct LaunchPlan {
  std::filesystem::path run_dir;
  std::string agent_binary;  ///< the `swarmloc` binary; the lean swarmloc-agent beside it is preferred
  bool record = false;       ///< --record: each agent logs the samples it receives
  std::vector<AgentId> hostile_agents;
};

/// A process to start: its arguments and where its stdout/stderr go.
struct ProcessCommand {
  std::vector<std::string> argv;
  std::string output_path;
};

/// How to start an agent process: the lean swarmloc-agent beside `agent_binary` (the `swarmloc` binary) when
/// it is there, else `<agent_binary> agent`, which runs the same code.
std::vector<std::string> agent_executable(const std::string& agent_binary);

/// Agent `id`'s process (incarnation > 0: a restart after faults.kill, with its own log). The agent learns
/// what it may know from its manifest; it never builds the world.
ProcessCommand agent_process(const LaunchPlan& plan, AgentId id, int incarnation);

/// The fusion centre of a centralized algorithm.
ProcessCommand fusion_centre_process(const LaunchPlan& plan);

}  // namespace swarmloc::orchestrator
