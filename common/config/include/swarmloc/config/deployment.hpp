#pragma once
// A live deployment (docs/live.md): the team of robots and anchors that run swarmloc on their own
// sensors, with no world and no orchestrator. Each robot's agent and the monitor read the same file.
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/core/types.hpp"

namespace swarmloc::config {

/// An invalid deployment file: what() names the file and the key ("team[2].id: ...").
class DeploymentError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// One member of the team: a robot, or an anchor (a fixed range beacon whose position is known; its agent
/// runs like a robot's, on any host, and reads the anchor's ranges if its driver publishes any).
struct TeamMember {
  std::string name;  ///< ROS namespace of its topics and frames: /<name>/ranges, <name>/base_link
  AgentId id = 0;
  std::optional<Vec2> anchor;  ///< the anchor's position in the map frame
  std::optional<Vec2> start;   ///< a robot's rough start position (default: the anchors' centroid)
};

/// What tells a driver that stopped, a clock that jumped (docs/robustness.md, "Live sensor input").
struct LiveLimits {
  double silence_s = 1.0;     ///< no sweep this long: the driver counts as stopped
  double clock_jump_s = 1.0;  ///< stamps and arrivals disagree by more: the robot's clock jumped
};

struct Deployment {
  std::string name = "live";     ///< the run's name and dds.run_id
  std::vector<TeamMember> team;  ///< sorted by id; ids are 0 … N−1
  std::string algorithm = "dml";
  double rate_hz = 10.0;  ///< estimator steps per second (run.rate_hz)
  int domain_id = 0;
  double start_std_m = 5.0;      ///< how far a robot's start may be off (world.initial_guess_std_m)
  double comm_radius_m = 1.0e9;  ///< radio range, if known (world.comm_radius_m; default: unlimited)
  std::vector<std::string>
      overrides;  ///< `set:` scenario keys (docs/scenario.md), e.g. noise.range_std_m=0.1
  std::string map_frame = "map";
  std::string base_frame = "base_link";  ///< each robot's tf child frame is <name>/<base_frame>
  std::string ranges_topic = "ranges";   ///< relative to the robot's namespace
  std::string odom_topic = "odom";
  std::string pose_topic = "pose";
  std::string truth_topic;  ///< ground truth (PoseStamped) per robot; empty: none
  LiveLimits limits;

  [[nodiscard]] const TeamMember* find(const std::string& robot) const;
  /// "rt/<robot>/<topic>": the DDS name of a ROS topic in the robot's namespace.
  [[nodiscard]] static std::string dds_topic(const std::string& robot, const std::string& topic);
};

/// Parses and validates deployment YAML; `origin` names the source in errors. Throws DeploymentError.
Deployment parse_deployment(const std::string& yaml_text, const std::string& origin = "<string>");
/// Reads and parses a deployment file. Throws DeploymentError.
Deployment load_deployment(const std::string& path);

/// The scenario every agent of the deployment runs: its algorithm and rate, the team's size and anchors,
/// free run, the `set:` keys applied. Throws DeploymentError (naming the key) if a key is invalid.
Scenario deployment_scenario(const Deployment& deployment);

}  // namespace swarmloc::config
