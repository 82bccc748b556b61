#pragma once
// One vehicle of a MURP UWB team as its own process (`swarmloc-agent --uwb-team FILE --vehicle N --team
// 1,2,3`, started by `swarmloc replay --murp DIR`; docs/real-data.md, "MURP over DDS"): it reads its range
// model from the calibration file, takes its windows from the orchestrator, and runs the two rounds of each
// window with its teammates (uwb_team_rounds.hpp). Like every agent it never sees the truth.
#include <string>
#include <vector>

#include "swarmloc/core/types.hpp"

namespace swarmloc::agent {

struct UwbTeamAgentOptions {
  std::string calibration_path;  ///< a `swarmloc calibrate --murp --out` file (the run's range_model.json)
  AgentId vehicle = -1;
  std::vector<AgentId> team;  ///< every vehicle of the team, this one included
  int domain_id = 0;
  bool cooperate = true;  ///< false: report own-range estimates (no loop closure)
  std::string log_path;   ///< empty: stderr
  /// With no window input (or stop) for this long the orchestrator is taken to be gone: exit 1.
  double idle_timeout_s = 60.0;
  /// How long a round waits for its teammates before it proceeds with what arrived.
  double round_timeout_s = 5.0;
};

/// Runs until the orchestrator's stop (0), SIGINT/SIGTERM (0), bad arguments or an unreadable calibration
/// (2), or a DDS failure or a silent orchestrator (1).
int run_uwb_team_agent(const UwbTeamAgentOptions& options);

}  // namespace swarmloc::agent
