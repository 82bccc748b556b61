#pragma once
// The live-agent acceptance tests (test_live.cpp, test_live_faults.cpp, docs/live.md): a recorded world
// turned into a deployment file and the live player's input, and one live run — an agent process per
// team member, `swarmloc monitor`, and tests/live_player playing the recording into the robots' topics.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "process_helpers.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/rundir/recording.hpp"

namespace swarmloc::testing {

inline const std::string kLiveSwarmloc = SWARMLOC_BINARY;
inline const std::string kLiveAgent = SWARMLOC_AGENT_BINARY;
inline const std::string kLivePlayer = SWARMLOC_LIVE_PLAYER;
inline const std::string kLiveSource = SWARMLOC_SOURCE_DIR;
inline constexpr int kLiveSteps = 200;
inline constexpr double kLiveRateHz = 10.0;

/// A static world of 7 robots and 3 anchors, every pair in range, recorded by the simulator.
struct LiveWorld {
  std::filesystem::path dir;
  std::filesystem::path recording;
  std::filesystem::path player_input;
  std::filesystem::path deployment;
  std::vector<std::string> names;
  std::vector<bool> anchor;
  std::vector<Vec2> final_truth;
};

inline std::string live_robot_name(int id) { return "r" + std::to_string(id); }

/// The recording's ranges and truth as the player reads them.
inline void write_live_player_input(const rundir::Recording& recording, const std::filesystem::path& path) {
  std::ofstream out(path);
  out.precision(17);
  for (int id = 0; id < recording.agents(); ++id) out << "name " << id << " " << live_robot_name(id) << "\n";
  for (std::int64_t step = 0; step < recording.steps(); ++step) {
    const auto truth = recording.truth(step);
    for (int id = 0; id < recording.agents(); ++id) {
      out << "truth " << step << " " << id << " " << truth[static_cast<std::size_t>(id)].x() << " "
          << truth[static_cast<std::size_t>(id)].y() << "\n";
      for (const auto& range : recording.batch(id, step).ranges)
        out << "range " << step << " " << id << " " << range.peer << " " << range.range_m << " "
            << range.std_m << "\n";
    }
  }
}

/// The deployment of the recorded team: anchors at their positions, robots starting where the recorded
/// agents started, the recorded world's radio range and start uncertainty.
inline void write_live_deployment(const rundir::Recording& recording, const config::Scenario& scenario,
                                  int domain, const std::filesystem::path& path) {
  std::ofstream out(path);
  out.precision(17);
  out << "name: live" << domain << "\ndomain_id: " << domain << "\nrate_hz: " << scenario.run.rate_hz
      << "\nalgorithm: " << scenario.algorithm.name << "\nstart_std_m: " << scenario.world.initial_guess_std_m
      << "\ncomm_radius_m: " << scenario.world.comm_radius_m << "\ntopics: {truth: truth}\nteam:\n";
  const auto truth = recording.truth(0);
  for (int id = 0; id < recording.agents(); ++id) {
    const auto i = static_cast<std::size_t>(id);
    const Vec2 where = recording.world().is_anchor[i] ? truth[i] : recording.world().initial_guess[i];
    out << "  - {name: " << live_robot_name(id) << ", id: " << id << ", "
        << (recording.world().is_anchor[i] ? "anchor" : "start") << ": [" << where.x() << ", " << where.y()
        << "]}\n";
  }
}

inline LiveWorld make_live_world(const std::string& name, int domain) {
  LiveWorld world;
  world.dir = fresh_directory(name);
  const auto recorded = world.dir / "recorded";
  const CommandResult sim = run_command(
      kLiveSwarmloc + " sim " + kLiveSource + "/scenarios/default.yaml -q --record --out " +
      recorded.string() +
      " --set algorithm.name=dml --set world.agents=10 --set world.anchors=3 --set world.area_m=20" +
      " --set world.comm_radius_m=40 --set run.steps=" + std::to_string(kLiveSteps) + " --set seed=41");
  if (sim.exit_code != 0) throw std::runtime_error("swarmloc sim failed: " + sim.output);
  world.recording = recorded / "recording.slrec";
  const auto recording = rundir::load_recording(world.recording);
  const config::Scenario scenario = config::parse_scenario(recording->scenario_yaml());
  world.player_input = world.dir / "player_input.txt";
  world.deployment = world.dir / "deployment.yaml";
  write_live_player_input(*recording, world.player_input);
  write_live_deployment(*recording, scenario, domain, world.deployment);
  for (int id = 0; id < recording->agents(); ++id) {
    world.names.push_back(live_robot_name(id));
    world.anchor.push_back(recording->world().is_anchor[static_cast<std::size_t>(id)]);
  }
  world.final_truth = recording->truth(recording->steps() - 1);
  return world;
}

struct LiveTf {
  std::string parent;
  std::int64_t stamp_ns = 0;
  Vec2 position = Vec2::Zero();
};

/// What one live run left: the player's view (poses, tf, publications), each agent's counters and the
/// monitor's run directory.
struct LiveRun {
  CommandResult script;
  std::map<std::string, Vec2> last_pose;                       ///< robot -> its newest pose
  std::map<std::string, std::map<std::int64_t, Vec2>> poses;   ///< robot -> stamp -> position
  std::map<std::string, std::vector<LiveTf>> tf;               ///< child frame -> transforms
  std::set<std::pair<std::string, std::string>> publications;  ///< (topic, type) of rt/ writers
  std::map<std::string, nlohmann::json> stats;                 ///< robot -> --stats JSON
  std::filesystem::path monitor_dir;
  nlohmann::json view;  ///< the monitor's live view (/state.json) as the player finished
};

inline void read_live_player_output(const std::filesystem::path& path, LiveRun& run) {
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string kind;
    fields >> kind;
    if (kind == "pose") {
      std::string robot, frame;
      std::int64_t sec = 0, nanosec = 0;
      double x = 0, y = 0;
      fields >> robot >> sec >> nanosec >> frame >> x >> y;
      run.last_pose[robot] = Vec2(x, y);
      run.poses[robot][sec * 1'000'000'000 + nanosec] = Vec2(x, y);
    } else if (kind == "tf") {
      std::string parent, child;
      std::int64_t sec = 0, nanosec = 0;
      double x = 0, y = 0;
      fields >> parent >> child >> sec >> nanosec >> x >> y;
      run.tf[child].push_back({parent, sec * 1'000'000'000 + nanosec, Vec2(x, y)});
    } else if (kind == "publication") {
      std::string topic, type;
      fields >> topic >> type;
      if (topic.rfind("rt/", 0) == 0) run.publications.emplace(topic, type);
    }
  }
}

/// Starts every team member's agent and the monitor, plays the recording (robot `fault` misbehaving, −1:
/// none), then stops the agents with SIGTERM and waits for everything.
inline LiveRun run_live(const LiveWorld& world, int domain, int fault) {
  LiveRun run;
  const auto dir = world.dir / ("run" + std::to_string(fault + 1));
  std::filesystem::create_directories(dir);
  run.monitor_dir = dir / "monitor";
  std::string script = "cd " + dir.string() + " && pids=''; ";
  for (const auto& name : world.names) {
    script += kLiveAgent + " --live " + world.deployment.string() + " --robot " + name + " --stats " + name +
              ".json --log " + name + ".log --duration 180 & pids=\"$pids $!\"; ";
  }
  const std::string port = std::to_string(free_port());
  script += kLiveSwarmloc + " monitor -q --deployment " + world.deployment.string() + " --out " +
            run.monitor_dir.string() + " --idle 3 --duration 180 --view " + port +
            " > monitor.log 2>&1 & mon=$!; ";
  script += "CYCLONEDDS_URI=file://" + kLiveSource + "/deploy/ros2/cyclonedds.xml " + kLivePlayer + " " +
            std::to_string(domain) + " " + world.player_input.string() + " player.txt " +
            std::to_string(kLiveRateHz) + " --fault " + std::to_string(fault) +
            " --linger 0.5 > player.log 2>&1; ";
  script += "echo player=$?; curl -s -m 5 http://127.0.0.1:" + port +
            "/state.json > view.json; kill -TERM $pids; for p in $pids; do wait $p; echo agent=$?; done; "
            "wait $mon; "
            "echo monitor=$?";
  run.script = run_command("bash -c '" + script + "'");
  read_live_player_output(dir / "player.txt", run);
  for (const auto& name : world.names) {
    if (std::filesystem::exists(dir / (name + ".json"))) run.stats[name] = read_json(dir / (name + ".json"));
  }
  run.view = nlohmann::json::parse(read_text(dir / "view.json"), nullptr, false);
  return run;
}

/// RMSE over the robots (not anchors) of their newest pose against the final truth.
inline double live_rmse(const LiveWorld& world, const LiveRun& run) {
  double sum = 0.0;
  int count = 0;
  for (std::size_t i = 0; i < world.names.size(); ++i) {
    if (world.anchor[i]) continue;
    const auto pose = run.last_pose.find(world.names[i]);
    if (pose == run.last_pose.end()) return std::numeric_limits<double>::infinity();
    sum += (pose->second - world.final_truth[i]).squaredNorm();
    ++count;
  }
  return std::sqrt(sum / count);
}

}  // namespace swarmloc::testing
