#include "replay.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include "calibrate.hpp"
#include "orchestrator.hpp"
#include "swarmloc/rundir/recording.hpp"
#include "swarmloc/world/mrclam.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::orchestrator {
namespace {

/// What a replay runs: the scenario (overrides applied), the recorded steps, and where they came from.
struct ReplaySource {
  config::Scenario scenario;
  std::shared_ptr<const world::RecordedSteps> steps;
  nlohmann::json provenance = nlohmann::json::object();
  nlohmann::json baselines;  ///< --mrclam: summary.json's "baselines"
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

std::string kinds_text(const world::MeasurementKinds& k) {
  std::string text;
  auto add = [&](bool on, const char* name) {
    if (on) text += (text.empty() ? "" : ", ") + std::string(name);
  };
  add(k.ranges, "ranges");
  add(k.anchor_fixes, "anchor fixes");
  add(k.relative, "relative positions");
  add(k.paths, "reflected paths");
  add(k.targets, "target readings");
  add(k.field, "field readings");
  return text.empty() ? "nothing" : text;
}

/// The replayed algorithm must consume what the recorded one was fed (ranges, relative positions,
/// reflected paths or target readings); a missing kind would leave it without measurements.
void check_measurement_kinds(const std::string& recorded_algorithm, const std::string& algorithm) {
  const auto had = world::measurement_kinds(recorded_algorithm);
  const auto needs = world::measurement_kinds(algorithm);
  if ((needs.ranges && !had.ranges) || (needs.relative && !had.relative) || (needs.paths && !had.paths) ||
      (needs.targets && !had.targets) || (needs.field && !had.field)) {
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
  const auto recording = rundir::load_recording(path);
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
  const auto difference = recording->world().difference(world::build_world(scenario));
  if (!difference.empty()) {
    throw config::ScenarioError(path + ": the scenario no longer builds the recorded world (" + difference +
                                "; a changed positions file?)");
  }
  source.steps = recording;
  source.provenance = {{"recording", path},
                       {"recorded_steps", recording->steps()},
                       {"recorded_algorithm", recorded.algorithm.name},
                       {"recorded_scenario_hash", config::scenario_hash(recorded)},
                       {"overrides", overrides}};
  return source;
}

/// The scenario of `replay --mrclam` before its noise model and the --set overrides (docs/real-data.md
/// explains each choice). The noise model is the dataset's own, measured as `swarmloc calibrate` does, or
/// --noise FILE.
constexpr const char* kMrclamScenario = R"(name: mrclam
algorithm:
  name: team_pose_ekf
  process_noise_std_m: 0.01
  initial_std_m: 0.05
  initial_heading_std_rad: 0.05
  range_bearing_gate_chi2: 13.8
world:
  source: mrclam
  data_step_s: 0.1
  agents: 5
  anchors: 0
run:
  mode: free_run
)";

/// A JSON number, or null for NaN/Inf (a baseline without a usable covariance has no NEES).
nlohmann::json number_or_null(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json();
}

/// summary.json's baselines.<name>: RMSE over the run and at the final step, and the 3-DOF NEES of both.
nlohmann::json baseline_json(const world::MrclamBaseline& baseline) {
  return {{"rmse_m", baseline.rmse_m},
          {"final_rmse_m", baseline.final_rmse_m},
          {"nees3", number_or_null(baseline.nees3)},
          {"final_nees3", number_or_null(baseline.final_nees3)}};
}

/// baselines.batch_smoother: the baseline's figures and how its solve went (docs/real-data.md).
nlohmann::json smoother_json(const world::MrclamSmootherBaseline& smoother) {
  auto block = baseline_json(smoother);
  block["iterations"] = smoother.iterations;
  block["gating_rounds"] = smoother.gating_rounds;
  block["converged"] = smoother.converged;
  block["range_bearings_used"] = smoother.range_bearings_used;
  block["range_bearings_gated"] = smoother.range_bearings_gated;
  block["solve_s"] = smoother.solve_s;
  return block;
}

void print_baselines(const world::MrclamBaselines& baselines) {
  std::printf(
      "  baselines (RMSE over the run, 5 robots; NEES3, 3 = consistent): dead reckoning %.4f m (%.2f), "
      "centralized EKF %.4f m (%.2f)",
      baselines.dead_reckoning.rmse_m, baselines.dead_reckoning.nees3, baselines.centralized_ekf.rmse_m,
      baselines.centralized_ekf.nees3);
  if (const auto& smoother = baselines.batch_smoother) {
    std::printf(", batch smoother %.4f m (%.2f; %d iterations, %s, %.2f s)", smoother->rmse_m,
                smoother->nees3, smoother->iterations, smoother->converged ? "converged" : "NOT converged",
                smoother->solve_s);
  }
  std::printf("\n");
  std::fflush(stdout);
}

/// --noise FILE: its text, which may hold comments and one top-level block, `noise:` (what `calibrate
/// --out` writes); anything else would silently change the replay's other settings.
std::string noise_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw config::ScenarioError("--noise: cannot read '" + path + "'");
  std::ostringstream text;
  text << in.rdbuf();
  std::istringstream lines(text.str());
  std::string line;
  bool noise_block = false;
  for (int number = 1; std::getline(lines, line); ++number) {
    if (line.empty() || line[0] == ' ' || line[0] == '#' || line[0] == '\r') continue;
    const auto rest = line.find_first_not_of(" \r", 6);
    if (line.rfind("noise:", 0) != 0 || (rest != std::string::npos && line[rest] != '#')) {
      std::ostringstream message;
      message << "--noise " << path << ":" << number
              << ": only a noise: block may be given (as `swarmloc calibrate --out` writes it), found '"
              << line << "'";
      throw config::ScenarioError(message.str());
    }
    noise_block = true;
  }
  if (!noise_block) throw config::ScenarioError("--noise " + path + ": no noise: block");
  return text.str();
}

/// The dataset's own noise model, measured against its groundtruth (`swarmloc calibrate`), as YAML.
std::string measured_noise(const std::string& dir) {
  const auto c = [&] {
    try {
      return measure_mrclam_noise(dir);
    } catch (const config::ScenarioError& error) {
      throw config::ScenarioError(std::string(error.what()) +
                                  ": the dataset's noise cannot be measured; give a model with --noise FILE");
    }
  }();
  const auto& landmarks = c.pooled.landmarks;
  spdlog::info(
      "noise measured from the dataset's groundtruth (swarmloc calibrate; --noise FILE replays with "
      "another): landmark range std {:.4f} m, bearing std {:.4f} rad, odometry {:.4f} m/√s and {:.4f} "
      "rad/√s over {:.1f} s, command lag {:.2f} s",
      landmarks.range_m.std, landmarks.bearing_rad.std, c.pooled.horizon.v_rms_with_tails(),
      c.pooled.horizon.omega_rms_with_tails(), c.pooled.horizon.window_s, c.odometry_lag.lag_s);
  return noise_fragment(dir, c);
}

/// `replay --mrclam DIR`: the dataset as the world, every recorded step unless run.steps is set, the
/// wall rate = speedup / data_step_s, and both baselines computed in-process on the same steps.
ReplaySource mrclam_source(const ReplayOptions& options) {
  if (!(options.speedup > 0.0) || options.speedup > 1e4) {
    throw config::ScenarioError("--speedup: " + std::to_string(options.speedup) + " is outside (0, 10000]");
  }
  std::error_code error;
  const auto dir = std::filesystem::absolute(options.mrclam_dir, error).lexically_normal();
  std::vector<std::string> overrides{"world.data_dir=" + dir.string()};
  bool steps_set = false;
  for (const auto& text : options.overrides) {
    steps_set = steps_set || override_key(text) == "run.steps";
    overrides.push_back(text);
  }
  const auto noise =
      options.noise_path.empty() ? measured_noise(dir.string()) : noise_file(options.noise_path);
  // The noise block comes first, so that an error in a --noise file names its own line.
  const auto origin = options.noise_path.empty() ? std::string("replay --mrclam") : options.noise_path;
  auto scenario = config::parse_scenario(noise + "\n" + kMrclamScenario, overrides, origin);
  if (!std::any_of(options.overrides.begin(), options.overrides.end(),
                   [](const std::string& text) { return override_key(text) == "run.rate_hz"; })) {
    scenario.run.rate_hz = options.speedup / scenario.world.data_step_s;
  }
  const auto dataset_steps = [&] {
    auto probe = scenario;
    probe.run.steps = 1;
    return world::build_world(probe).recorded->steps();
  }();
  if (!steps_set) scenario.run.steps = static_cast<int>(dataset_steps);
  config::validate(scenario);
  const auto world = world::build_world(scenario);
  spdlog::info("UTIAS MRCLAM {}: {} steps of {} s ({:.0f} s of data) at {:.0f}x real time; baselines first",
               dir.string(), scenario.run.steps, scenario.world.data_step_s,
               scenario.run.steps * scenario.world.data_step_s, options.speedup);
  const auto baselines = world::mrclam_baselines(scenario, world);
  ReplaySource source;
  source.scenario = scenario;
  source.provenance = {
      {"mrclam", dir.string()},
      {"speedup", options.speedup},
      {"dataset_steps", dataset_steps},
      {"noise", options.noise_path.empty() ? std::string("measured from the dataset") : options.noise_path}};
  source.baselines = {{"dead_reckoning", baseline_json(baselines.dead_reckoning)},
                      {"centralized_ekf", baseline_json(baselines.centralized_ekf)}};
  if (baselines.batch_smoother) source.baselines["batch_smoother"] = smoother_json(*baselines.batch_smoother);
  print_baselines(baselines);
  return source;
}

}  // namespace

int run_replay(const ReplayOptions& options) {
  ReplaySource source;
  const bool mrclam = !options.mrclam_dir.empty();
  try {
    if (mrclam && !options.recording_path.empty()) {
      throw config::ScenarioError("replay: give a recording FILE or --mrclam DIR, not both");
    }
    if (!mrclam && !options.noise_path.empty()) {
      throw config::ScenarioError(
          "replay: --noise applies to --mrclam DIR (a recording keeps its own noise)");
    }
    if (!mrclam && options.recording_path.empty()) {
      throw config::ScenarioError("replay: a recording FILE (or --mrclam DIR) is required");
    }
    source = mrclam ? mrclam_source(options) : recording_source(options.recording_path, options.overrides);
  } catch (const rundir::RecordingError& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 2;
  } catch (const config::ScenarioError& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 2;
  } catch (const std::exception& error) {
    // Anything else while reading the input (a dataset file, memory for a huge recording) is still about
    // the input: a message and exit 2, never an uncaught exception (exit 134).
    std::fprintf(stderr, "error: replay: %s\n", error.what());
    return 2;
  }
  const bool dds = mrclam ? !options.in_process : options.dds;
  if (!mrclam) {
    spdlog::info("replaying {}: {} of {} recorded steps, algorithm {}{}", options.recording_path,
                 source.scenario.run.steps, source.steps->steps(), source.scenario.algorithm.name,
                 dds ? " over DDS" : " in the simulator");
  }
  nlohmann::json extra = {{"replay", source.provenance}};
  if (!source.baselines.is_null()) extra["baselines"] = source.baselines;
  if (dds) {
    // The run directory is prepared (prepare_run_directory: writable, empty unless --force) by the
    // runtime, before any work.
    RunOptions run;
    run.out_dir = options.out_dir;
    run.force = options.force;
    run.agent_binary = options.agent_binary;
    run.progress = options.progress;
    run.record = options.record;
    run.recorded = source.steps;
    run.summary_extra = extra;
    return run_orchestrator(std::move(source.scenario), run);
  }
  SimCommandOptions sim;
  sim.out_dir = options.out_dir;
  sim.force = options.force;
  sim.progress = options.progress;
  sim.record = options.record;
  sim.recorded = source.steps;
  sim.summary_extra = extra;
  return run_sim_command(std::move(source.scenario), sim);
}

}  // namespace swarmloc::orchestrator
