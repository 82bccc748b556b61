// validate(): every range and cross-field rule, in document order, each message starting with the key path.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "scenario_keys.hpp"
#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/config/scenario.hpp"

namespace swarmloc::config {
namespace {

using detail::format_number;

[[noreturn]] void fail(std::string_view path, const std::string& message) {
  throw ScenarioError(std::string(path) + ": " + message);
}

void require_finite(double value, std::string_view path) {
  if (!std::isfinite(value)) fail(path, format_number(value) + " is not a finite number");
}

void require_positive(double value, std::string_view path) {
  require_finite(value, path);
  if (!(value > 0.0)) fail(path, format_number(value) + " must be > 0");
}

void require_non_negative(double value, std::string_view path) {
  require_finite(value, path);
  if (value < 0.0) fail(path, format_number(value) + " must be >= 0");
}

void require_within(double value, double low, double high, std::string_view path) {
  require_finite(value, path);
  if (value < low || value > high) {
    fail(path,
         format_number(value) + " is outside [" + format_number(low) + ", " + format_number(high) + "]");
  }
}

void require_within(int value, int low, int high, std::string_view path) {
  if (value < low || value > high) {
    fail(path,
         std::to_string(value) + " is outside [" + std::to_string(low) + ", " + std::to_string(high) + "]");
  }
}

void require_at_least(int value, int low, std::string_view path) {
  if (value < low) fail(path, std::to_string(value) + " must be >= " + std::to_string(low));
}

void require_non_empty(const std::string& value, std::string_view path) {
  if (value.empty()) fail(path, "must not be empty");
}

/// `name` becomes a path component, runs/<name>-<stamp>-seed<seed> (docs/robustness.md, "Outputs are
/// complete or the run fails"): one component inside runs/, short enough for a file name with the stamp.
void validate_name(const std::string& name) {
  constexpr std::size_t kMaxLength = 100;
  require_non_empty(name, "name");
  if (name.size() > kMaxLength) {
    fail("name", "is " + std::to_string(name.size()) + " bytes long; at most " + std::to_string(kMaxLength));
  }
  if (name.find('/') != std::string::npos) fail("name", "must not contain '/' (it names the run directory)");
  if (name.find("..") != std::string::npos)
    fail("name", "must not contain '..' (it names the run directory)");
  if (name.front() == '.') fail("name", "must not start with '.' (it names the run directory)");
  for (const char c : name) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte < 0x20 || byte == 0x7f) fail("name", "must not contain control characters");
  }
}

void validate_qos(const QosSettings& qos, const std::string& family) {
  const std::string prefix = "qos." + family + ".";
  require_at_least(qos.history_depth, 1, prefix + "history_depth");
  require_non_negative(qos.deadline_s, prefix + "deadline_s");
  require_non_negative(qos.liveliness_lease_s, prefix + "liveliness_lease_s");
}

/// Gilbert–Elliott bursts (core/link_model.hpp): 0 = off (Bernoulli); otherwise a mean burst length in
/// samples, at least 1/(1 − loss) (the mean burst of independent loss; shorter bursts at the same mean
/// loss would need anti-correlated losses, which the model does not have) and at most kMaxBurst.
void validate_burst(const Scenario::Network& network) {
  constexpr double kMaxBurst = 1000.0;
  constexpr std::string_view kPath = "network.burst.mean_length";
  const double length = network.burst.mean_length;
  require_finite(length, kPath);
  if (length == 0.0) return;
  require_within(length, 1.0, kMaxBurst, kPath);
  if (network.loss >= 1.0) return;  // every sample is dropped; the burst length is moot
  const double shortest = 1.0 / (1.0 - network.loss);
  // A relative slack so that a value written as 1/(1 − loss) to 17 digits is accepted.
  if (length < shortest * (1.0 - 1e-12)) {
    fail(kPath, format_number(length) + " is shorter than 1/(1 - network.loss) = " + format_number(shortest) +
                    ", the mean burst of independent loss at network.loss " + format_number(network.loss) +
                    " (use 0 for Bernoulli loss)");
  }
}

/// Enums set by casting an out-of-range integer (only possible from code, never from YAML).
void validate_enums(const Scenario& scenario) {
  for (const auto& key : detail::key_specs()) {
    const std::string value = key.write(scenario);
    if (value.starts_with("invalid_")) fail(key.path, "invalid enum value " + value.substr(8));
  }
}

void validate_agent_counts(const Scenario::World& world) {
  require_within(world.agents, 1, 100000, "world.agents");
  require_at_least(world.anchors, 0, "world.anchors");
  if (world.anchors > world.agents) {
    fail("world.anchors",
         std::to_string(world.anchors) + " is more than world.agents (" + std::to_string(world.agents) + ")");
  }
}

/// The pose algorithms need the UTIAS MRCLAM recordings (odometry and range-bearing), and the recordings
/// fix the team: 5 robots, none of them an anchor.
void validate_data_source(const Scenario& scenario, const AlgorithmSpec& spec) {
  const auto& world = scenario.world;
  const auto& algorithm = scenario.algorithm;
  const bool pose_algorithm = spec.family == AlgorithmFamily::kPose;
  require_within(world.data_step_s, 0.001, 10.0, "world.data_step_s");
  if (world.source == WorldSource::kMrclam) {
    if (world.data_dir.empty())
      fail("world.data_dir", "must name the dataset directory when world.source is mrclam");
    if (world.agents != 5) {
      fail("world.agents",
           std::to_string(world.agents) + ": UTIAS MRCLAM has 5 robots (set world.agents: 5)");
    }
    if (world.anchors != 0)
      fail("world.anchors", "UTIAS MRCLAM robots are not anchors (set world.anchors: 0)");
    if (!pose_algorithm) {
      fail("algorithm.name", "'" + algorithm.name +
                                 "' cannot use UTIAS MRCLAM data (range-bearing and odometry): use pose_ekf, "
                                 "pose_ieif or dead_reckoning");
    }
  } else if (pose_algorithm) {
    fail("algorithm.name",
         "'" + algorithm.name + "' needs odometry and range-bearing data: set world.source: mrclam");
  } else {
    const auto& noise = scenario.noise;
    for (const auto& [key, value] : {std::pair{"noise.range_bias_m", noise.range_bias_m},
                                     std::pair{"noise.range_bias_per_rad", noise.range_bias_per_rad},
                                     std::pair{"noise.range_bias_per_rad2", noise.range_bias_per_rad2},
                                     std::pair{"noise.robot_range_bias_m", noise.robot_range_bias_m}}) {
      if (value != 0.0) {
        fail(key,
             "a camera's range bias is removed from recorded sightings only (world.source: mrclam); "
             "generated worlds draw unbiased ranges");
      }
    }
    if (noise.odometry_lag_s != 0.0) {
      fail("noise.odometry_lag_s",
           "the command lag is removed from recorded odometry only (world.source: mrclam)");
    }
  }
}

void validate_layout(const Scenario::World& world) {
  require_positive(world.area_m, "world.area_m");
  require_positive(world.comm_radius_m, "world.comm_radius_m");
  if (world.placement == Placement::kFile && world.positions_file.empty()) {
    fail("world.positions_file", "must be set when world.placement is file");
  }
  require_non_negative(world.motion_std_m, "world.motion_std_m");
  require_non_negative(world.initial_guess_std_m, "world.initial_guess_std_m");
  require_within(world.wall_count, 0, 16, "world.wall_count");
  require_finite(world.wall_first_angle_deg, "world.wall_first_angle_deg");
  require_finite(world.wall_angle_step_deg, "world.wall_angle_step_deg");
  require_non_negative(world.wall_margin_m, "world.wall_margin_m");
}

void validate_target_and_field(const Scenario::World& world) {
  require_finite(world.target_x_m, "world.target_x_m");
  require_finite(world.target_y_m, "world.target_y_m");
  // 1 km/s is far beyond any target this runtime tracks; more is a unit mistake.
  require_within(world.target_vx_mps, -1000.0, 1000.0, "world.target_vx_mps");
  require_within(world.target_vy_mps, -1000.0, 1000.0, "world.target_vy_mps");
  require_within(world.target_accel_psd, 0.0, 1e6, "world.target_accel_psd");
  require_non_negative(world.target_sensing_radius_m, "world.target_sensing_radius_m");
  require_within(world.field_cells_per_side, 1, 8, "world.field_cells_per_side");
  require_non_negative(world.field_std, "world.field_std");
  require_positive(world.field_correlation_m, "world.field_correlation_m");
  require_positive(world.field_sensing_radius_m, "world.field_sensing_radius_m");
}

/// world.dimensions: 3 is a range world of generated positions, for the algorithms that run in 3-D (its truth
/// may move: the fusion-centre filters predict in every coordinate; dml's own rule keeps it static).
void validate_dimensions(const Scenario& scenario, const AlgorithmSpec& spec) {
  const auto& world = scenario.world;
  if (world.dimensions != 2 && world.dimensions != 3) fail("world.dimensions", "must be 2 or 3");
  require_positive(world.height_m, "world.height_m");
  if (world.dimensions == 2) return;
  if (!spec.three_dimensional) {
    fail("world.dimensions", "3 needs an algorithm that runs in 3-D (dml, ekf, lbekf, lbekf_vr, lbekf_i); '" +
                                 scenario.algorithm.name + "' is planar");
  }
  if (world.source != WorldSource::kGenerated) fail("world.dimensions", "3 needs a generated world");
  if (world.placement != Placement::kUniform)
    fail("world.placement", "must be uniform when world.dimensions is 3");
}

void validate_world(const Scenario& scenario, const AlgorithmSpec& spec) {
  validate_agent_counts(scenario.world);
  validate_dimensions(scenario, spec);
  validate_data_source(scenario, spec);
  validate_layout(scenario.world);
  validate_target_and_field(scenario.world);
}

void validate_noise(const Scenario::Noise& noise) {
  require_non_negative(noise.range_std_m, "noise.range_std_m");
  require_non_negative(noise.anchor_fix_std_m, "noise.anchor_fix_std_m");
  require_within(noise.range_factor, 0.0, 10.0, "noise.range_factor");
  require_non_negative(noise.relative_std_m, "noise.relative_std_m");
  require_within(noise.doa_error_deg, 0.0, 90.0, "noise.doa_error_deg");
  require_within(noise.bearing_std_rad, 1e-6, 3.2, "noise.bearing_std_rad");
  require_within(noise.odometry_v_std, 0.0, 100.0, "noise.odometry_v_std");
  require_within(noise.odometry_omega_std, 0.0, 100.0, "noise.odometry_omega_std");
  require_within(noise.odometry_lag_s, 0.0, 5.0, "noise.odometry_lag_s");
  require_within(noise.sighting_correlation_time_s, 0.0, 1e6, "noise.sighting_correlation_time_s");
  require_within(noise.sighting_cluster_radius_m, 0.0, 1e6, "noise.sighting_cluster_radius_m");
  require_within(noise.range_bias_m, -100.0, 100.0, "noise.range_bias_m");
  require_within(noise.range_bias_per_rad, -100.0, 100.0, "noise.range_bias_per_rad");
  require_within(noise.range_bias_per_rad2, -100.0, 100.0, "noise.range_bias_per_rad2");
  require_within(noise.robot_range_bias_m, -100.0, 100.0, "noise.robot_range_bias_m");
  require_within(noise.range_correlated_fraction, 0.0, 0.99, "noise.range_correlated_fraction");
  require_within(noise.bearing_correlated_fraction, 0.0, 0.99, "noise.bearing_correlated_fraction");
  require_non_negative(noise.target_std_m, "noise.target_std_m");
  require_within(noise.target_bearing_std_rad, 1e-6, 3.2, "noise.target_bearing_std_rad");
  require_non_negative(noise.field_std, "noise.field_std");
}

void validate_network(const Scenario::Network& network) {
  require_within(network.loss, 0.0, 1.0, "network.loss");
  validate_burst(network);
  // 10 s is far beyond any network this runtime targets; anything larger is a unit mistake (s vs ms).
  constexpr double kMaxDelayMs = 10000.0;
  require_within(network.delay_ms, 0.0, kMaxDelayMs, "network.delay_ms");
  require_within(network.jitter_ms, 0.0, kMaxDelayMs, "network.jitter_ms");
}

void validate_clock(const Scenario::Clock& clock) {
  // drift_ppm is the magnitude of a ± bound drawn per agent; 1e5 ppm = 10 %.
  require_within(clock.drift_ppm, 0.0, 1e5, "clock.drift_ppm");
  require_non_negative(clock.offset_max_s, "clock.offset_max_s");
}

/// Rules for run.agent_steps_per_world_step above 1 (several agent steps per world step).
void validate_extra_agent_steps(const Scenario& scenario, const AlgorithmSpec& spec) {
  const auto& run = scenario.run;
  // The Kalman family and the pose filters predict on a step without a batch (process noise per step);
  // the centralized ones have no agent steps.
  if (!spec.exchange_only) {
    const auto& exchange_only = exchange_only_algorithms();
    std::string list;
    for (const auto& name : exchange_only) list += (list.empty() ? "" : ", ") + name;
    fail("run.agent_steps_per_world_step",
         "above 1 needs an algorithm whose step without a measurement is an exchange only (" + list + "); '" +
             scenario.algorithm.name + "' would predict on every extra step");
  }
  if (run.mode == RunMode::kLockstep) {
    fail("run.agent_steps_per_world_step",
         "above 1 is not supported with run.mode = lockstep (use free_run)");
  }
  if (run.rate_hz * run.agent_steps_per_world_step > 10000.0) {
    fail("run.agent_steps_per_world_step", "run.rate_hz × this is above 10 kHz of agent steps");
  }
}

void validate_run(const Scenario& scenario, const AlgorithmSpec& spec) {
  const auto& run = scenario.run;
  require_at_least(run.steps, 1, "run.steps");
  require_finite(run.rate_hz, "run.rate_hz");
  if (!(run.rate_hz > 0.0) || run.rate_hz > 1000.0) {
    fail("run.rate_hz", format_number(run.rate_hz) + " is outside (0, 1000]");
  }
  require_positive(run.startup_timeout_s, "run.startup_timeout_s");
  require_non_negative(run.settle_s, "run.settle_s");
  require_within(run.agent_nice, 0, 19, "run.agent_nice");
  require_within(run.agent_steps_per_world_step, 1, 1000, "run.agent_steps_per_world_step");
  if (run.agent_steps_per_world_step > 1) validate_extra_agent_steps(scenario, spec);
  // Only the simulator's agents clock models latency: a delay under rounds would silently do nothing.
  if (run.sim_clock == SimClock::kRounds) {
    if (scenario.network.delay_ms != 0.0) fail("network.delay_ms", "needs run.sim_clock = agents");
    if (scenario.network.jitter_ms != 0.0) fail("network.jitter_ms", "needs run.sim_clock = agents");
  }
}

void validate_all_qos(const Scenario::Qos& qos) {
  validate_qos(qos.measurements, "measurements");
  validate_qos(qos.state, "state");
  validate_qos(qos.information, "information");
  validate_qos(qos.consensus, "consensus");
  validate_qos(qos.belief, "belief");
  validate_qos(qos.estimate, "estimate");
  validate_qos(qos.control, "control");
}

void validate_dds(const Scenario::Dds& dds) {
  require_within(dds.domain_id, 0, 230, "dds.domain_id");
  if (!dds.run_id.empty() && !valid_run_id(dds.run_id)) {
    throw ScenarioError("dds.run_id: '" + dds.run_id + "' must be 1 to 32 characters of [A-Za-z0-9_-]");
  }
}

/// Every fault names an existing agent and starts before the run ends.
void check_fault_range(const std::vector<AgentFault>& faults, const std::string& key,
                       const Scenario& scenario) {
  for (const auto& fault : faults) {
    if (fault.agent < 0 || fault.agent >= scenario.world.agents) {
      fail(key, "agent " + std::to_string(fault.agent) + " is outside [0, world.agents)");
    }
    if (fault.from_step >= scenario.run.steps) {
      fail(key, "step " + std::to_string(fault.from_step) + " is not before run.steps (" +
                    std::to_string(scenario.run.steps) + ")");
    }
  }
}

void validate_lockstep_faults(const std::vector<AgentFault>& kills, const std::vector<AgentFault>& pauses) {
  // The lockstep barrier waits for every living agent each step: a paused agent or a restarted one
  // (fresh step counter, joining mid-run) would be timed out and then run without its neighbours'
  // samples. Refuse rather than score that.
  if (!pauses.empty()) fail("faults.pause", "is not supported with run.mode = lockstep (use free_run)");
  for (const auto& kill : kills) {
    if (kill.to_step >= 0) {
      fail("faults.kill",
           "restarts (agent@from-to) are not supported with run.mode = lockstep; kill without "
           "a restart (agent@step) or use free_run");
    }
  }
}

void validate_faults(const Scenario& scenario) {
  const auto kills = parse_agent_faults(scenario.faults.kill, "faults.kill", false);
  const auto pauses = parse_agent_faults(scenario.faults.pause, "faults.pause", true);
  check_fault_range(kills, "faults.kill", scenario);
  check_fault_range(pauses, "faults.pause", scenario);
  if (scenario.run.mode == RunMode::kLockstep) validate_lockstep_faults(kills, pauses);
  (void)parse_partition(scenario.faults.partition);
}

}  // namespace

namespace detail {

void validate_kalman_params(const Scenario& scenario) {
  const KalmanParams& kalman = scenario.algorithm.kalman;
  require_non_negative(kalman.process_noise_std_m, "algorithm.process_noise_std_m");
  require_positive(kalman.initial_information, "algorithm.initial_information");
  require_positive(kalman.initial_std_m, "algorithm.initial_std_m");
  require_non_negative(kalman.range_gate_chi2, "algorithm.range_gate_chi2");
  require_within(kalman.update_iterations, 1, 100, "algorithm.update_iterations");
}

void validate_pose_params(const Scenario& scenario) {
  const PoseParams& pose = scenario.algorithm.pose;
  require_positive(pose.initial_heading_std_rad, "algorithm.initial_heading_std_rad");
  require_non_negative(pose.range_bearing_gate_chi2, "algorithm.range_bearing_gate_chi2");
  require_within(pose.team_share_spans, 1, 64, "algorithm.team_share_spans");
  require_within(pose.team_wait_steps, 0, 1'000'000, "algorithm.team_wait_steps");
}

void validate_gradient_params(const Scenario& scenario) {
  const GradientParams& gradient = scenario.algorithm.gradient;
  require_within(gradient.consensus_rounds, 1, 10000, "algorithm.consensus_rounds");
  require_positive(gradient.fixed_step, "algorithm.fixed_step");
  require_positive(gradient.step_length, "algorithm.step_length");
  require_non_negative(gradient.max_step, "algorithm.max_step");
  require_within(gradient.max_move_fraction, 0.0, 10.0, "algorithm.max_move_fraction");
  require_positive(gradient.abs_tol, "algorithm.abs_tol");
}

void validate_field_params(const Scenario& scenario) {
  require_within(scenario.algorithm.field.field_warmup_steps, 0, 1000000, "algorithm.field_warmup_steps");
}

void validate_multipath_params(const Scenario& /*scenario*/) {}  // two enums, checked by validate_enums

}  // namespace detail

void validate(const Scenario& scenario) {
  validate_enums(scenario);
  validate_name(scenario.name);
  const AlgorithmSpec& spec = algorithm_spec(scenario.algorithm.name);
  for (const auto& block : param_blocks()) block.validate(scenario);
  validate_world(scenario, spec);
  validate_noise(scenario.noise);
  // The algorithm's own rules (algorithms.cpp), once every world and noise key is in range.
  if (spec.validate != nullptr) spec.validate(scenario);
  validate_network(scenario.network);
  validate_clock(scenario.clock);
  validate_run(scenario, spec);
  validate_all_qos(scenario.qos);
  validate_dds(scenario.dds);
  validate_faults(scenario);
}

namespace {

[[noreturn]] void fault_syntax(const std::string& key, const std::string& item, const std::string& expected) {
  fail(key, "'" + item + "' is not " + expected);
}

std::int64_t parse_step(const std::string& text, const std::string& key, const std::string& item,
                        const std::string& expected) {
  std::int64_t value = 0;
  const auto* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ec != std::errc{} || ptr != end || value < 0) fault_syntax(key, item, expected);
  return value;
}

std::vector<std::string> split_items(const std::string& text) {
  std::vector<std::string> items;
  std::string item;
  for (const char c : text + ",") {
    if (c == ',') {
      if (!item.empty()) items.push_back(item);
      item.clear();
    } else if (c != ' ' && c != '\t') {
      item += c;
    }
  }
  return items;
}

}  // namespace

std::vector<AgentFault> parse_agent_faults(const std::string& text, const std::string& key,
                                           bool require_end) {
  const std::string expected = require_end ? "AGENT@STEP-STEP" : "AGENT@STEP or AGENT@STEP-STEP";
  std::vector<AgentFault> faults;
  for (const auto& item : split_items(text)) {
    const auto at = item.find('@');
    if (at == std::string::npos) fault_syntax(key, item, expected);
    AgentFault fault;
    const auto agent = parse_step(item.substr(0, at), key, item, expected);
    if (agent > 100000) fault_syntax(key, item, expected);
    fault.agent = static_cast<AgentId>(agent);
    const std::string steps = item.substr(at + 1);
    const auto dash = steps.find('-');
    if (dash == std::string::npos) {
      if (require_end) fault_syntax(key, item, expected);
      fault.from_step = parse_step(steps, key, item, expected);
    } else {
      fault.from_step = parse_step(steps.substr(0, dash), key, item, expected);
      fault.to_step = parse_step(steps.substr(dash + 1), key, item, expected);
      if (fault.to_step <= fault.from_step)
        fail(key, "'" + item + "': the second step must be after the first");
    }
    faults.push_back(fault);
  }
  return faults;
}

std::optional<StepWindow> parse_partition(const std::string& text) {
  const auto items = split_items(text);
  if (items.empty()) return std::nullopt;
  const std::string key = "faults.partition";
  if (items.size() > 1) fail(key, "'" + text + "': one window STEP-STEP");
  const auto dash = items[0].find('-');
  if (dash == std::string::npos) fault_syntax(key, items[0], "STEP-STEP");
  StepWindow window;
  window.from_step = parse_step(items[0].substr(0, dash), key, items[0], "STEP-STEP");
  window.to_step = parse_step(items[0].substr(dash + 1), key, items[0], "STEP-STEP");
  if (window.to_step < window.from_step)
    fail(key, "'" + items[0] + "': the second step must not be before the first");
  return window;
}

}  // namespace swarmloc::config
