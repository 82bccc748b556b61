#include "replay.hpp"

#include <spdlog/spdlog.h>

#include <cstdio>
#include <memory>

#include "orchestrator.hpp"
#include "swarmloc/sim/centralized_runner.hpp"
#include "swarmloc/sim/recording.hpp"
#include "swarmloc/sim/world.hpp"

namespace swarmloc::orchestrator {
namespace {

/// What a replay runs: the scenario (overrides applied), the recorded steps, and where they came from.
struct ReplaySource {
  config::Scenario scenario;
  std::shared_ptr<const sim::RecordedSteps> steps;
  bool pose_measurements = false;  ///< odometry / range-bearing batches (not on the DDS wire yet)
  nlohmann::json provenance = nlohmann::json::object();
};

/// The key of a "key=value" override.
std::string override_key(const std::string& text) { return text.substr(0, text.find('=')); }

/// A replay keeps the recorded world: overrides of the seed or world.* would rebuild another one.
void reject_world_overrides(const std::vector<std::string>& overrides) {
  for (const auto& text : overrides) {
    const auto key = override_key(text);
    if (key == "seed" || key.starts_with("world.")) {
      throw config::ScenarioError(
          "replay: --set " + key +
          " would change the recorded world; a replay keeps the recording's seed and "
          "world.* keys (algorithm.*, noise model assumptions, network.*, run.*, clock.* "
          "and dds.* may change)");
    }
  }
}

std::string kinds_text(const sim::MeasurementKinds& k) {
  std::string text;
  auto add = [&](bool on, const char* name) {
    if (on) text += (text.empty() ? "" : ", ") + std::string(name);
  };
  add(k.ranges, "ranges");
  add(k.anchor_fixes, "anchor fixes");
  add(k.relative, "relative positions");
  add(k.paths, "reflected paths");
  return text.empty() ? "nothing" : text;
}

/// The replayed algorithm must consume what the recorded one was fed (ranges, relative positions or
/// reflected paths); a missing kind would leave it without measurements.
void check_measurement_kinds(const std::string& recorded_algorithm, const std::string& algorithm) {
  const auto had = sim::measurement_kinds(recorded_algorithm);
  const auto needs = sim::measurement_kinds(algorithm);
  if ((needs.ranges && !had.ranges) || (needs.relative && !had.relative) || (needs.paths && !had.paths)) {
    throw config::ScenarioError("algorithm.name: " + algorithm + " consumes " + kinds_text(needs) +
                                " but the recording (" + recorded_algorithm + ") holds " + kinds_text(had));
  }
  if (needs.anchor_fixes && !had.anchor_fixes) {
    spdlog::warn("the recording ({}) has no anchor fixes; {} anchors start from their known position only",
                 recorded_algorithm, algorithm);
  }
}

/// Loads a recording file and checks that the overridden scenario replays it unchanged.
ReplaySource recording_source(const std::string& path, const std::vector<std::string>& overrides) {
  const auto recording = sim::load_recording(path);
  reject_world_overrides(overrides);
  const std::string origin = path + " (recorded scenario)";
  const auto recorded = config::parse_scenario(recording->scenario_yaml(), {}, origin);
  ReplaySource source;
  source.scenario = config::parse_scenario(recording->scenario_yaml(), overrides, origin);
  auto& scenario = source.scenario;
  if (scenario.world.agents != recording->agents()) {
    throw config::ScenarioError(
        path + ": the recorded scenario has world.agents = " + std::to_string(scenario.world.agents) +
        " but the file holds " + std::to_string(recording->agents()) + " agents");
  }
  if (scenario.run.steps > recording->steps()) {
    throw config::ScenarioError("run.steps: " + std::to_string(scenario.run.steps) + " steps asked but " +
                                path + " holds " + std::to_string(recording->steps()) +
                                " (a replay can run at most the recorded steps)");
  }
  check_measurement_kinds(recorded.algorithm.name, scenario.algorithm.name);
  const auto difference = recording->world().difference(sim::build_world(scenario));
  if (!difference.empty()) {
    throw config::ScenarioError(path + ": the scenario no longer builds the recorded world (" + difference +
                                "; a changed positions file?)");
  }
  source.steps = recording;
  source.pose_measurements = recording->has_pose_measurements();
  source.provenance = {{"recording", path},
                       {"recorded_steps", recording->steps()},
                       {"recorded_algorithm", recorded.algorithm.name},
                       {"recorded_scenario_hash", config::scenario_hash(recorded)},
                       {"overrides", overrides}};
  return source;
}

}  // namespace

int run_replay(const ReplayOptions& options) {
  ReplaySource source;
  try {
    if (options.recording_path.empty()) throw config::ScenarioError("replay: a recording FILE is required");
    source = recording_source(options.recording_path, options.overrides);
    if (options.dds && source.pose_measurements) {
      throw config::ScenarioError(options.recording_path +
                                  ": odometry and range-bearing measurements are not carried over DDS yet; "
                                  "replay it in the simulator (without --dds)");
    }
  } catch (const sim::RecordingError& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 2;
  } catch (const config::ScenarioError& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 2;
  }
  spdlog::info("replaying {}: {} of {} recorded steps, algorithm {}{}", options.recording_path,
               source.scenario.run.steps, source.steps->steps(), source.scenario.algorithm.name,
               options.dds ? " over DDS" : " in the simulator");
  const nlohmann::json extra = {{"replay", source.provenance}};
  if (options.dds) {
    RunOptions run;
    run.out_dir = options.out_dir;
    run.agent_binary = options.agent_binary;
    run.progress = options.progress;
    run.record = options.record;
    run.recorded = source.steps;
    run.summary_extra = extra;
    return run_orchestrator(std::move(source.scenario), run);
  }
  SimCommandOptions sim;
  sim.out_dir = options.out_dir;
  sim.progress = options.progress;
  sim.record = options.record;
  sim.recorded = source.steps;
  sim.summary_extra = extra;
  return run_sim_command(std::move(source.scenario), sim);
}

}  // namespace swarmloc::orchestrator
