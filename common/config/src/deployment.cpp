// Live deployment files (deployment.hpp, docs/live.md).
#include "swarmloc/config/deployment.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

namespace swarmloc::config {
namespace {

[[noreturn]] void deployment_fail(const std::string& origin, const std::string& key,
                                  const std::string& what) {
  throw DeploymentError(origin + ": " + key + ": " + what);
}

/// Every key of `node` must be one of `known`: a misspelt key is an error, never a silent default.
void deployment_known_keys(const YAML::Node& node, const std::string& origin, const std::string& where,
                           std::initializer_list<const char*> known) {
  for (const auto& entry : node) {
    const auto key = entry.first.as<std::string>();
    if (std::none_of(known.begin(), known.end(), [&key](const char* name) { return key == name; }))
      deployment_fail(origin, where + key, "unknown key");
  }
}

template <typename T>
void deployment_read(const YAML::Node& node, const char* key, T& value, const std::string& origin,
                     const std::string& where) {
  if (!node[key]) return;
  try {
    value = node[key].as<T>();
  } catch (const YAML::Exception&) {
    deployment_fail(origin, where + key, "wrong type");
  }
}

Vec2 deployment_point(const YAML::Node& node, const std::string& origin, const std::string& key) {
  if (!node.IsSequence() || node.size() != 2) deployment_fail(origin, key, "must be [x, y] in metres");
  try {
    const Vec2 point(node[0].as<double>(), node[1].as<double>());
    if (!point.allFinite()) deployment_fail(origin, key, "must be finite");
    return point;
  } catch (const YAML::Exception&) {
    deployment_fail(origin, key, "must be [x, y] in metres");
  }
}

/// A ROS name segment: the robot's namespace and frame prefix.
bool deployment_ros_name(const std::string& name) {
  if (name.empty() || !(std::isalpha(static_cast<unsigned char>(name[0])) || name[0] == '_')) return false;
  return std::all_of(name.begin(), name.end(),
                     [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
}

TeamMember deployment_member(const YAML::Node& node, const std::string& origin, const std::string& where) {
  if (!node.IsMap()) deployment_fail(origin, where, "must be a map with name and id");
  deployment_known_keys(node, origin, where + ".", {"name", "id", "anchor", "start"});
  TeamMember member;
  member.id = -1;
  deployment_read(node, "name", member.name, origin, where + ".");
  deployment_read(node, "id", member.id, origin, where + ".");
  if (!deployment_ros_name(member.name))
    deployment_fail(origin, where + ".name",
                    "'" + member.name + "' is not a ROS name ([A-Za-z_][A-Za-z0-9_]*)");
  if (node["anchor"]) member.anchor = deployment_point(node["anchor"], origin, where + ".anchor");
  if (node["start"]) member.start = deployment_point(node["start"], origin, where + ".start");
  if (member.anchor && member.start) deployment_fail(origin, where + ".start", "an anchor has no start");
  return member;
}

void deployment_check_team(const Deployment& deployment, const std::string& origin) {
  if (deployment.team.empty()) deployment_fail(origin, "team", "lists no robot");
  std::set<std::string> names;
  for (std::size_t k = 0; k < deployment.team.size(); ++k) {
    const TeamMember& member = deployment.team[k];
    if (member.id != static_cast<AgentId>(k))
      deployment_fail(origin, "team",
                      "ids must be 0 … " + std::to_string(deployment.team.size() - 1) + ", each once (id " +
                          std::to_string(k) + " is missing or repeated)");
    if (!names.insert(member.name).second)
      deployment_fail(origin, "team", "name '" + member.name + "' repeats");
  }
  const bool any_robot = std::any_of(deployment.team.begin(), deployment.team.end(),
                                     [](const TeamMember& member) { return !member.anchor; });
  if (!any_robot) deployment_fail(origin, "team", "lists only anchors");
}

void deployment_read_nested(const YAML::Node& root, Deployment& d, const std::string& origin) {
  if (const YAML::Node frames = root["frames"]) {
    deployment_known_keys(frames, origin, "frames.", {"map", "base"});
    deployment_read(frames, "map", d.map_frame, origin, "frames.");
    deployment_read(frames, "base", d.base_frame, origin, "frames.");
  }
  if (const YAML::Node topics = root["topics"]) {
    deployment_known_keys(topics, origin, "topics.", {"ranges", "odom", "pose", "truth"});
    deployment_read(topics, "ranges", d.ranges_topic, origin, "topics.");
    deployment_read(topics, "odom", d.odom_topic, origin, "topics.");
    deployment_read(topics, "pose", d.pose_topic, origin, "topics.");
    deployment_read(topics, "truth", d.truth_topic, origin, "topics.");
  }
  if (const YAML::Node limits = root["limits"]) {
    deployment_known_keys(limits, origin, "limits.", {"silence_s", "clock_jump_s"});
    deployment_read(limits, "silence_s", d.limits.silence_s, origin, "limits.");
    deployment_read(limits, "clock_jump_s", d.limits.clock_jump_s, origin, "limits.");
  }
}

void deployment_check_values(const Deployment& d, const std::string& origin) {
  if (!(d.rate_hz > 0.0 && d.rate_hz <= 1000.0)) deployment_fail(origin, "rate_hz", "must be in (0, 1000]");
  if (!(d.limits.silence_s > 0.0)) deployment_fail(origin, "limits.silence_s", "must be > 0");
  if (!(d.limits.clock_jump_s > 0.0)) deployment_fail(origin, "limits.clock_jump_s", "must be > 0");
  for (const auto* frame : {&d.map_frame, &d.base_frame, &d.ranges_topic, &d.odom_topic, &d.pose_topic}) {
    if (frame->empty()) deployment_fail(origin, "frames/topics", "names must not be empty");
  }
}

}  // namespace

const TeamMember* Deployment::find(const std::string& robot) const {
  const auto it =
      std::find_if(team.begin(), team.end(), [&robot](const TeamMember& m) { return m.name == robot; });
  return it == team.end() ? nullptr : &*it;
}

std::string Deployment::dds_topic(const std::string& robot, const std::string& topic) {
  return "rt/" + robot + "/" + topic;
}

Deployment parse_deployment(const std::string& yaml_text, const std::string& origin) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& error) {
    throw DeploymentError(origin + ": " + error.what());
  }
  if (!root.IsMap()) throw DeploymentError(origin + ": a deployment is a YAML map (docs/live.md)");
  deployment_known_keys(root, origin, "",
                        {"name", "team", "algorithm", "rate_hz", "domain_id", "start_std_m", "comm_radius_m",
                         "set", "frames", "topics", "limits"});
  Deployment d;
  deployment_read(root, "name", d.name, origin, "");
  deployment_read(root, "algorithm", d.algorithm, origin, "");
  deployment_read(root, "rate_hz", d.rate_hz, origin, "");
  deployment_read(root, "domain_id", d.domain_id, origin, "");
  deployment_read(root, "start_std_m", d.start_std_m, origin, "");
  deployment_read(root, "comm_radius_m", d.comm_radius_m, origin, "");
  deployment_read(root, "set", d.overrides, origin, "");
  deployment_read_nested(root, d, origin);
  const YAML::Node team = root["team"];
  if (!team || !team.IsSequence()) deployment_fail(origin, "team", "must list the robots and anchors");
  for (std::size_t k = 0; k < team.size(); ++k)
    d.team.push_back(deployment_member(team[k], origin, "team[" + std::to_string(k) + "]"));
  std::sort(d.team.begin(), d.team.end(),
            [](const TeamMember& a, const TeamMember& b) { return a.id < b.id; });
  deployment_check_team(d, origin);
  deployment_check_values(d, origin);
  deployment_scenario(d);  // the algorithm and `set:` keys are checked here, not at an agent's start
  return d;
}

Deployment load_deployment(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw DeploymentError(path + ": cannot be read");
  std::stringstream text;
  text << in.rdbuf();
  return parse_deployment(text.str(), path);
}

Scenario deployment_scenario(const Deployment& d) {
  const auto anchors =
      std::count_if(d.team.begin(), d.team.end(), [](const TeamMember& m) { return m.anchor; });
  std::ostringstream number;
  number.precision(17);
  auto key = [&number](const std::string& name, double value) {
    number.str("");
    number << value;
    return name + "=" + number.str();
  };
  std::vector<std::string> keys = {
      "name=" + d.name,
      "algorithm.name=" + d.algorithm,
      key("run.rate_hz", d.rate_hz),
      "run.mode=free_run",
      "dds.domain_id=" + std::to_string(d.domain_id),
      "dds.run_id=" + d.name,
      "world.agents=" + std::to_string(d.team.size()),
      "world.anchors=" + std::to_string(anchors),
      key("world.initial_guess_std_m", d.start_std_m),
      key("world.comm_radius_m", d.comm_radius_m),
  };
  keys.insert(keys.end(), d.overrides.begin(), d.overrides.end());
  try {
    return parse_scenario("{}", keys, "deployment " + d.name);
  } catch (const ScenarioError& error) {
    throw DeploymentError(std::string("deployment: ") + error.what());
  }
}

}  // namespace swarmloc::config
