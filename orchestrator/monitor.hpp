#pragma once
// `swarmloc monitor` (docs/live.md): joins a live deployment's domain, records the pose every agent
// publishes and, where the robots have one, their ground-truth topic, and writes a run directory like
// any run's: estimates, metrics and plots scored against the truth, and summary.json with health.
// Without truth it says so and scores nothing.
#include <string>

namespace swarmloc::orchestrator {

struct MonitorOptions {
  std::string deployment_path;
  std::string out_dir;
  std::string truth_topic;  ///< overrides the deployment's topics.truth ("none": no truth)
  double duration_s = 0.0;  ///< > 0: stop after this long
  double idle_s = 5.0;      ///< stop once poses came and then none for this long
  int view_port = -1;       ///< >= 0: serve the live view (live_view.hpp) on this port (0: any free one)
  bool force = false;
  bool quiet = false;
};

/// Exit codes: 0 ok, 2 bad input, 1 runtime failure.
int run_monitor(const MonitorOptions& options);

}  // namespace swarmloc::orchestrator
