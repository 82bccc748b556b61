#pragma once
// `swarmloc agent --role agent`: the agent process of the full binary. With --manifest it is the lean
// `swarmloc-agent`; without, for agents started elsewhere (`run --no-launch`, containers, other hosts)
// that have no manifest file, it builds the world from the scenario to learn its own manifest (every
// agent repeats the orchestrator's world: O(N) start-up per agent).
#include "agent_node.hpp"

namespace swarmloc::orchestrator {

/// Returns the process exit code (0 ok, 2 bad input, 1 runtime failure).
int run_agent_command(const agent::AgentOptions& options);

}  // namespace swarmloc::orchestrator
