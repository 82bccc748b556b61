#include "agent_command.hpp"

namespace swarmloc::orchestrator {

int run_agent_command(const agent::AgentOptions& options) { return agent::run_agent(options); }

}  // namespace swarmloc::orchestrator
