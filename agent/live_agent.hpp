#pragma once
// swarmloc-agent --live: one robot's agent fed by the robot's own ROS 2 sensor topics, with no orchestrator
// (docs/live.md). It runs the same agent loop as an orchestrated agent (runtime/agent_loop.hpp); what
// differs is where measurements come from (live_input.hpp checks them) and where estimates go (the robot's
// pose topic and tf).
#include <string>

#include "swarmloc/config/deployment.hpp"
#include "swarmloc/runtime/manifest.hpp"

namespace swarmloc::agent {

struct LiveOptions {
  std::string deployment_path;
  std::string robot;        ///< the team member this process is
  std::string log_path;     ///< empty: stderr
  std::string stats_path;   ///< JSON of the input counters and steps, written at exit; empty: none
  double duration_s = 0.0;  ///< > 0: stop after this long (tests); otherwise on SIGINT/SIGTERM
};

/// The manifest of `member` in `deployment`: every other member is a neighbour (the team shares one
/// network), an anchor knows its position, a robot starts at its `start` or the anchors' centroid.
runtime::AgentManifest live_manifest(const config::Deployment& deployment, const config::Scenario& scenario,
                                     const config::TeamMember& member);

/// Runs until stopped. Exit codes as run_agent: 0 ok, 2 bad input, 1 runtime failure.
int run_live_agent(const LiveOptions& options);

}  // namespace swarmloc::agent
