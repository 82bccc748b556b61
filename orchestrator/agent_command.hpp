#pragma once
// `swarmloc agent --role agent`: the agent process of the full binary, the same code as the lean
// `swarmloc-agent`. Its manifest is the file given with --manifest, or (agents started elsewhere: `run
// --no-launch`, containers, other hosts) the orchestrator's manifest sample over DDS. It never builds
// the world.
#include "agent_node.hpp"

namespace swarmloc::orchestrator {

/// Returns the process exit code (0 ok, 2 bad input, 1 runtime failure or no manifest in time).
int run_agent_command(const agent::AgentOptions& options);

}  // namespace swarmloc::orchestrator
