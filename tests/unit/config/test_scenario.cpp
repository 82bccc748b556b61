// Scenario loading, overrides, validation and serialization (common/config).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "swarmloc/config/scenario.hpp"

namespace swarmloc::config {
namespace {

const std::string kSourceDir = SWARMLOC_SOURCE_DIR;
const std::string kFixtures = kSourceDir + "/tests/data/scenarios/";

/// Runs `action`, expects a ScenarioError, and returns its message ("" and a failure when none is thrown).
std::string error_of(const std::function<void()>& action) {
  try {
    action();
  } catch (const ScenarioError& error) {
    return error.what();
  }
  ADD_FAILURE() << "expected a ScenarioError";
  return {};
}

std::string override_error(const std::vector<std::string>& overrides) {
  return error_of([&] { parse_scenario("", overrides); });
}

std::string validate_error(const std::function<void(Scenario&)>& change) {
  Scenario scenario;
  change(scenario);
  return error_of([&] { validate(scenario); });
}

bool starts_with(const std::string& text, const std::string& prefix) { return text.rfind(prefix, 0) == 0; }

#define EXPECT_STARTS_WITH(text, prefix) EXPECT_PRED2(starts_with, text, prefix)

void expect_qos_equal(const QosSettings& a, const QosSettings& b, const std::string& family) {
  SCOPED_TRACE(family);
  EXPECT_EQ(a.reliability, b.reliability);
  EXPECT_EQ(a.history_depth, b.history_depth);
  EXPECT_EQ(a.durability, b.durability);
  EXPECT_EQ(a.deadline_s, b.deadline_s);
  EXPECT_EQ(a.liveliness_lease_s, b.liveliness_lease_s);
}

/// Field by field, independent of to_yaml, so a field missing from the key table shows up here.
void expect_scenarios_equal(const Scenario& a, const Scenario& b) {
  EXPECT_EQ(a.seed, b.seed);
  EXPECT_EQ(a.name, b.name);
  EXPECT_EQ(a.algorithm.name, b.algorithm.name);
  EXPECT_EQ(a.algorithm.kalman.process_noise_std_m, b.algorithm.kalman.process_noise_std_m);
  EXPECT_EQ(a.algorithm.kalman.initial_information, b.algorithm.kalman.initial_information);
  EXPECT_EQ(a.algorithm.kalman.initial_std_m, b.algorithm.kalman.initial_std_m);
  EXPECT_EQ(a.algorithm.kalman.inflate_stale, b.algorithm.kalman.inflate_stale);
  EXPECT_EQ(a.algorithm.kalman.range_gate_chi2, b.algorithm.kalman.range_gate_chi2);
  EXPECT_EQ(a.algorithm.pose.initial_heading_std_rad, b.algorithm.pose.initial_heading_std_rad);
  EXPECT_EQ(a.algorithm.pose.range_bearing_gate_chi2, b.algorithm.pose.range_bearing_gate_chi2);
  EXPECT_EQ(a.algorithm.gradient.consensus_rounds, b.algorithm.gradient.consensus_rounds);
  EXPECT_EQ(a.algorithm.gradient.fixed_step, b.algorithm.gradient.fixed_step);
  EXPECT_EQ(a.algorithm.gradient.step_length, b.algorithm.gradient.step_length);
  EXPECT_EQ(a.algorithm.gradient.max_step, b.algorithm.gradient.max_step);
  EXPECT_EQ(a.algorithm.gradient.max_move_fraction, b.algorithm.gradient.max_move_fraction);
  EXPECT_EQ(a.algorithm.gradient.abs_tol, b.algorithm.gradient.abs_tol);
  EXPECT_EQ(a.world.agents, b.world.agents);
  EXPECT_EQ(a.world.anchors, b.world.anchors);
  EXPECT_EQ(a.world.area_m, b.world.area_m);
  EXPECT_EQ(a.world.comm_radius_m, b.world.comm_radius_m);
  EXPECT_EQ(a.world.placement, b.world.placement);
  EXPECT_EQ(a.world.positions_file, b.world.positions_file);
  EXPECT_EQ(a.world.motion, b.world.motion);
  EXPECT_EQ(a.world.motion_std_m, b.world.motion_std_m);
  EXPECT_EQ(a.world.initial_guess, b.world.initial_guess);
  EXPECT_EQ(a.world.initial_guess_std_m, b.world.initial_guess_std_m);
  EXPECT_EQ(a.world.require_connected, b.world.require_connected);
  EXPECT_EQ(a.world.target_motion, b.world.target_motion);
  EXPECT_EQ(a.world.target_x_m, b.world.target_x_m);
  EXPECT_EQ(a.world.target_y_m, b.world.target_y_m);
  EXPECT_EQ(a.world.target_vx_mps, b.world.target_vx_mps);
  EXPECT_EQ(a.world.target_vy_mps, b.world.target_vy_mps);
  EXPECT_EQ(a.world.target_accel_psd, b.world.target_accel_psd);
  EXPECT_EQ(a.world.target_sensing, b.world.target_sensing);
  EXPECT_EQ(a.world.target_sensing_radius_m, b.world.target_sensing_radius_m);
  EXPECT_EQ(a.noise.range_std_m, b.noise.range_std_m);
  EXPECT_EQ(a.noise.target_std_m, b.noise.target_std_m);
  EXPECT_EQ(a.noise.target_bearing_std_rad, b.noise.target_bearing_std_rad);
  EXPECT_EQ(a.algorithm.field.field_warmup_steps, b.algorithm.field.field_warmup_steps);
  EXPECT_EQ(a.algorithm.gradient.local_bb_difference, b.algorithm.gradient.local_bb_difference);
  EXPECT_EQ(a.algorithm.multipath.path_variance, b.algorithm.multipath.path_variance);
  EXPECT_EQ(a.algorithm.multipath.bp_messages, b.algorithm.multipath.bp_messages);
  EXPECT_EQ(a.world.field_cells_per_side, b.world.field_cells_per_side);
  EXPECT_EQ(a.world.field_std, b.world.field_std);
  EXPECT_EQ(a.world.field_correlation_m, b.world.field_correlation_m);
  EXPECT_EQ(a.world.field_sensing, b.world.field_sensing);
  EXPECT_EQ(a.world.field_sensing_radius_m, b.world.field_sensing_radius_m);
  EXPECT_EQ(a.noise.field_std, b.noise.field_std);
  EXPECT_EQ(a.noise.anchor_fix_std_m, b.noise.anchor_fix_std_m);
  EXPECT_EQ(a.network.loss, b.network.loss);
  EXPECT_EQ(a.network.burst.mean_length, b.network.burst.mean_length);
  EXPECT_EQ(a.network.delay_ms, b.network.delay_ms);
  EXPECT_EQ(a.network.jitter_ms, b.network.jitter_ms);
  EXPECT_EQ(a.clock.drift_ppm, b.clock.drift_ppm);
  EXPECT_EQ(a.clock.offset_max_s, b.clock.offset_max_s);
  EXPECT_EQ(a.run.steps, b.run.steps);
  EXPECT_EQ(a.run.rate_hz, b.run.rate_hz);
  EXPECT_EQ(a.run.mode, b.run.mode);
  EXPECT_EQ(a.run.startup_timeout_s, b.run.startup_timeout_s);
  EXPECT_EQ(a.run.settle_s, b.run.settle_s);
  EXPECT_EQ(a.run.agent_nice, b.run.agent_nice);
  EXPECT_EQ(a.run.sim_clock, b.run.sim_clock);
  EXPECT_EQ(a.run.agent_steps_per_world_step, b.run.agent_steps_per_world_step);
  EXPECT_EQ(a.run.tick_phase, b.run.tick_phase);
  expect_qos_equal(a.qos.measurements, b.qos.measurements, "measurements");
  expect_qos_equal(a.qos.state, b.qos.state, "state");
  expect_qos_equal(a.qos.information, b.qos.information, "information");
  expect_qos_equal(a.qos.consensus, b.qos.consensus, "consensus");
  expect_qos_equal(a.qos.belief, b.qos.belief, "belief");
  expect_qos_equal(a.qos.estimate, b.qos.estimate, "estimate");
  expect_qos_equal(a.qos.control, b.qos.control, "control");
  EXPECT_EQ(a.dds.domain_id, b.dds.domain_id);
  EXPECT_EQ(a.dds.interface, b.dds.interface);
  EXPECT_EQ(a.dds.neighbour_discovery, b.dds.neighbour_discovery);
  EXPECT_EQ(a.dds.peer_address, b.dds.peer_address);
  EXPECT_EQ(a.dds.security_dir, b.dds.security_dir);
}

/// A valid scenario where every field differs from its default.
Scenario everything_changed() {
  Scenario s;
  s.seed = std::numeric_limits<std::uint64_t>::max();
  s.name = "quotes \" back\\slash: colon # hash";
  s.algorithm.name = "dgbb";
  s.algorithm.kalman = {0.3, 1.0 / 3.0, 1e-300, false, 2.5, 100};
  s.algorithm.pose = {0.25, 13.8};
  s.algorithm.gradient = {7, 0.25, 3.5, 0.5, 1e-12, 9.0, LocalBbDifference::kGradientChange};
  s.world.agents = 100000;
  s.world.anchors = 0;
  s.world.area_m = 123.456789012345678;
  s.world.comm_radius_m = 0.1;
  s.world.placement = Placement::kFile;
  s.world.positions_file = "/tmp/pos itions.csv";
  s.world.motion = Motion::kRandomWalk;
  s.world.motion_std_m = 2.5e-7;
  s.world.initial_guess = InitialGuess::kUniform;
  s.world.initial_guess_std_m = 7.0;
  s.world.require_connected = false;
  s.noise = {0.2, 2.0, RangeNoise::kProportional, 0.05, true, 0.3, 2.5, NoiseDraw::kOnce};
  s.world.wall_count = 3;
  s.world.wall_first_angle_deg = 10.0;
  s.world.wall_angle_step_deg = 10.0;
  s.world.wall_margin_m = 0.5;
  s.world.target_motion = TargetMotion::kDoubleIntegrator;
  s.world.target_x_m = -3.25;
  s.world.target_y_m = 1e6;
  s.world.target_vx_mps = 1000.0;
  s.world.target_vy_mps = -0.5;
  s.world.target_accel_psd = 0.0;
  s.world.target_sensing = TargetSensing::kRangeBearing;
  s.world.target_sensing_radius_m = 12.0;
  s.noise.target_std_m = 0.0;
  s.noise.target_bearing_std_rad = 3.2;
  s.algorithm.field.field_warmup_steps = 1000000;
  s.algorithm.gradient.local_bb_difference = LocalBbDifference::kOwnMove;
  s.algorithm.multipath.path_variance = PathVariance::kWithDoa;
  s.algorithm.multipath.bp_messages = BpMessages::kExact;
  s.world.field_cells_per_side = 8;
  s.world.field_std = 0.0;
  s.world.field_correlation_m = 1e-3;
  s.world.field_sensing = FieldSensing::kCellBased;
  s.world.field_sensing_radius_m = 99.5;
  s.noise.field_std = 7.0;
  s.faults = {"3@0, 4@0", "", "0-0"};  // run.steps is 1; lockstep (below) takes kills without restarts
  s.network.loss = 1.0;
  s.network.burst.mean_length = 12.5;
  s.clock = {1e5, 0.25};
  s.network.delay_ms = 250.5;
  s.network.jitter_ms = 10000.0;
  s.run = {1, 1000.0, RunMode::kLockstep, 0.5, 0.0, SimClock::kAgents, 19};
  s.run.tick_phase = TickPhase::kAligned;
  s.qos.measurements = {Reliability::kBestEffort, 2, Durability::kTransientLocal, 1.5, 2.5};
  s.qos.state = {Reliability::kReliable, 3, Durability::kTransientLocal, 0.1, 0.2};
  s.qos.information = {Reliability::kReliable, 5, Durability::kTransientLocal, 0.3, 0.4};
  s.qos.consensus = {Reliability::kReliable, 6, Durability::kTransientLocal, 0.5, 0.6};
  s.qos.belief = {Reliability::kReliable, 7, Durability::kTransientLocal, 0.7, 0.8};
  s.qos.estimate = {Reliability::kBestEffort, 9, Durability::kTransientLocal, 0.9, 1.0};
  s.qos.control = {Reliability::kBestEffort, 10, Durability::kVolatile, 1.1, 1.2};
  s.dds = {230, "true", false, "null\nnewline\ttab \x01", "/etc/pki dir/~", "r-1_Z"};  // escapes in YAML
  return s;
}

// ---------------------------------------------------------------------------------------------------
// Defaults and valid input

TEST(Scenario, EmptyDocumentKeepsEveryDefault) {
  const Scenario parsed = parse_scenario("");
  expect_scenarios_equal(parsed, Scenario{});
  EXPECT_EQ(parsed.world.agents, 30);
  EXPECT_EQ(parsed.world.anchors, 8);
  EXPECT_EQ(parsed.algorithm.name, "ieif");
}

TEST(Scenario, StructDefaultsAreValid) { EXPECT_NO_THROW(validate(Scenario{})); }

TEST(Scenario, MissingKeysKeepTheirDefaults) {
  const Scenario parsed = parse_scenario("world:\n  agents: 50\nqos:\n  state:\n    history_depth: 3\n");
  Scenario expected;
  expected.world.agents = 50;
  expected.qos.state.history_depth = 3;
  expect_scenarios_equal(parsed, expected);
}

TEST(Scenario, DefaultScenarioFileLoadsAndEqualsTheStructDefaultsButForItsAlgorithm) {
  const Scenario loaded = load_scenario(kSourceDir + "/scenarios/default.yaml");
  Scenario expected;
  expected.algorithm.name = "dml";  // the first command's estimator; a file without algorithm.name runs ieif
  expect_scenarios_equal(loaded, expected);
  EXPECT_EQ(loaded.world.agents, 30);
  EXPECT_EQ(loaded.world.anchors, 8);
  EXPECT_EQ(loaded.world.area_m, 40.0);
  EXPECT_EQ(loaded.world.comm_radius_m, 15.0);
  EXPECT_EQ(loaded.noise.range_std_m, 0.1);
  EXPECT_EQ(loaded.run.rate_hz, 10.0);
  EXPECT_EQ(loaded.run.steps, 300);
  EXPECT_EQ(loaded.seed, 1U);
}

TEST(Scenario, FullFixtureSetsEveryKeyItNames) {
  const Scenario loaded = load_scenario(kFixtures + "valid_full.yaml");
  EXPECT_EQ(loaded.seed, std::numeric_limits<std::uint64_t>::max());
  EXPECT_EQ(loaded.name, "full fixture");
  EXPECT_EQ(loaded.algorithm.name, "iekf");
  EXPECT_EQ(loaded.algorithm.kalman.initial_information, 1e-3);
  EXPECT_FALSE(loaded.algorithm.kalman.inflate_stale);
  EXPECT_EQ(loaded.world.placement, Placement::kGrid);
  EXPECT_EQ(loaded.world.motion, Motion::kRandomWalk);
  EXPECT_EQ(loaded.world.initial_guess, InitialGuess::kUniform);
  EXPECT_FALSE(loaded.world.require_connected);
  EXPECT_EQ(loaded.network.loss, 0.3);
  EXPECT_EQ(loaded.clock.drift_ppm, 200.0);
  EXPECT_EQ(loaded.run.mode, RunMode::kLockstep);
  EXPECT_EQ(loaded.qos.measurements.history_depth, 8);
  EXPECT_EQ(loaded.qos.measurements.deadline_s, 0.5);
  EXPECT_EQ(loaded.qos.state.reliability, Reliability::kReliable);
  EXPECT_EQ(loaded.qos.state.history_depth, 2);
  EXPECT_EQ(loaded.qos.state.durability, Durability::kVolatile);  // unnamed: default kept
  EXPECT_EQ(loaded.qos.belief.durability, Durability::kTransientLocal);
  EXPECT_EQ(loaded.dds.domain_id, 42);
  EXPECT_EQ(loaded.dds.peer_address, "10.0.0.7");
  EXPECT_FALSE(loaded.dds.neighbour_discovery);
}

TEST(Scenario, RelativePositionsFileResolvesAgainstTheScenarioDirectory) {
  const Scenario loaded = load_scenario(kFixtures + "valid_positions_file.yaml");
  const auto expected = std::filesystem::absolute(kFixtures + "positions.csv").lexically_normal();
  EXPECT_EQ(loaded.world.positions_file, expected.string());
  EXPECT_TRUE(std::filesystem::path(loaded.world.positions_file).is_absolute());
}

TEST(Scenario, AbsolutePositionsFileIsKeptAsWritten) {
  const Scenario parsed = parse_scenario("world:\n  placement: file\n  positions_file: /data/p.csv\n");
  EXPECT_EQ(parsed.world.positions_file, "/data/p.csv");
}

TEST(Scenario, HyphenatedEnumSpellingIsAccepted) {
  EXPECT_EQ(parse_scenario("run:\n  mode: free-run\n").run.mode, RunMode::kFreeRun);
  EXPECT_EQ(parse_scenario("", {"world.motion=random-walk"}).world.motion, Motion::kRandomWalk);
}

TEST(Scenario, SpecialFloatSpellingsAndSignsParse) {
  EXPECT_EQ(parse_scenario("", {"network.loss=+0.5"}).network.loss, 0.5);
  EXPECT_EQ(parse_scenario("", {"world.area_m=1e2"}).world.area_m, 100.0);
  EXPECT_EQ(parse_scenario("", {"world.area_m=.5"}).world.area_m, 0.5);
  EXPECT_EQ(parse_scenario("", {"run.steps=+7"}).run.steps, 7);
}

// ---------------------------------------------------------------------------------------------------
// Overrides

TEST(Scenario, OverridesApplyOnTopOfTheFile) {
  const Scenario loaded = load_scenario(kSourceDir + "/scenarios/default.yaml",
                                        {"world.agents=40", "network.loss=0.3", "run.mode=lockstep",
                                         "algorithm.name=iekf", "qos.state.reliability=reliable", "seed=7"});
  EXPECT_EQ(loaded.world.agents, 40);
  EXPECT_EQ(loaded.network.loss, 0.3);
  EXPECT_EQ(loaded.run.mode, RunMode::kLockstep);
  EXPECT_EQ(loaded.algorithm.name, "iekf");
  EXPECT_EQ(loaded.qos.state.reliability, Reliability::kReliable);
  EXPECT_EQ(loaded.seed, 7U);
  EXPECT_EQ(loaded.world.anchors, 8);  // untouched keys keep the file's value
}

TEST(Scenario, LaterOverrideWinsOverEarlierOverrideAndFile) {
  const Scenario parsed = parse_scenario("world:\n  agents: 10\n", {"world.agents=20", "world.agents = 25"});
  EXPECT_EQ(parsed.world.agents, 25);
}

TEST(Scenario, OverridesApplyBeforeValidation) {
  // 40 anchors is invalid with the default 30 agents, valid once agents is raised too.
  EXPECT_NO_THROW(parse_scenario("", {"world.anchors=40", "world.agents=50"}));
  // And an invalid file value can be fixed from the command line.
  EXPECT_NO_THROW(load_scenario(kFixtures + "invalid_loss.yaml", {"network.loss=0.4"}));
}

TEST(Scenario, OverrideValueIsAYamlScalar) {
  EXPECT_EQ(parse_scenario("", {"name=\"a=b: c\""}).name, "a=b: c");
  EXPECT_EQ(parse_scenario("", {"algorithm.inflate_stale=false"}).algorithm.kalman.inflate_stale, false);
  EXPECT_EQ(parse_scenario("", {"world.positions_file="}).world.positions_file, "");
}

TEST(Scenario, EveryKnownKeyIsSettableByOverride) {
  // A list is never a valid value, so every known key must answer with a type error naming it —
  // never "unknown key".
  for (const auto& key : known_keys()) {
    const std::string message = override_error({key + "=[1, 2]"});
    EXPECT_STARTS_WITH(message, key + ": expected ");
  }
}

TEST(Scenario, KnownKeysIncludeTheCanonicalDesignKeys) {
  const auto& keys = known_keys();
  for (const char* key :
       {"seed", "algorithm.name", "world.agents", "world.anchors", "world.area_m", "world.comm_radius_m",
        "noise.range_std_m", "network.loss", "clock.drift_ppm", "clock.offset_max_s", "run.steps",
        "run.rate_hz", "run.mode", "qos.control.durability", "dds.domain_id"}) {
    EXPECT_NE(std::find(keys.begin(), keys.end(), key), keys.end()) << key;
  }
  EXPECT_EQ(keys.size(), 2U + 19U + 36U + 23U + 4U + 2U + 9U + 7U * 5U + 3U + 7U);
}

// ---------------------------------------------------------------------------------------------------
// Errors: every message starts with the key path

TEST(ScenarioErrors, NegativeRadiusNamesTheKey) {
  EXPECT_EQ(override_error({"world.comm_radius_m=-1"}),
            "world.comm_radius_m: -1 must be > 0 (from --set world.comm_radius_m=-1)");
  EXPECT_EQ(validate_error([](Scenario& s) { s.world.comm_radius_m = -1.0; }),
            "world.comm_radius_m: -1 must be > 0");
}

TEST(ScenarioErrors, ACamerasRangeBiasIsForRecordedDataOnly) {
  const std::vector<std::pair<std::string, std::function<void(Scenario&)>>> cases{
      {"noise.range_bias_m", [](Scenario& s) { s.noise.range_bias_m = 0.1; }},
      {"noise.range_bias_per_rad2", [](Scenario& s) { s.noise.range_bias_per_rad2 = -1.6; }},
      {"noise.robot_range_bias_m", [](Scenario& s) { s.noise.robot_range_bias_m = 0.04; }}};
  for (const auto& [key, set] : cases) {
    EXPECT_STARTS_WITH(validate_error(set),
                       key + ": a camera's range bias is removed from recorded sightings");
  }
  EXPECT_STARTS_WITH(validate_error([](Scenario& s) { s.noise.odometry_lag_s = 0.16; }),
                     "noise.odometry_lag_s: the command lag is removed from recorded odometry only");
}

TEST(ScenarioErrors, MoreAnchorsThanAgentsNamesTheAnchors) {
  EXPECT_EQ(validate_error([](Scenario& s) { s.world.anchors = 40; }),
            "world.anchors: 40 is more than world.agents (30)");
  const std::string message = error_of([] { load_scenario(kFixtures + "invalid_anchors.yaml"); });
  EXPECT_STARTS_WITH(message, "world.anchors: 40 is more than world.agents (30) at ");
  EXPECT_NE(message.find("invalid_anchors.yaml:4:"), std::string::npos) << message;
}

TEST(ScenarioErrors, UnknownAlgorithmListsTheKnownOnes) {
  const std::string message = override_error({"algorithm.name=foo"});
  EXPECT_STARTS_WITH(message, "algorithm.name: 'foo' is not a known algorithm (known: ieif, iekf, ekf, ");
  EXPECT_NE(message.find("fixed_step"), std::string::npos) << message;
}

TEST(ScenarioErrors, UnreadableFileNamesTheFileAndTheReason) {
  const std::string missing = kFixtures + "does_not_exist.yaml";
  EXPECT_EQ(error_of([&] { load_scenario(missing); }),
            "scenario file '" + missing + "': cannot be read (No such file or directory)");
  EXPECT_EQ(error_of([&] { load_scenario(kFixtures); }),
            "scenario file '" + kFixtures + "': cannot be read (Is a directory)");
}

TEST(ScenarioErrors, LossOutsideZeroToOneIsRejected) {
  EXPECT_EQ(validate_error([](Scenario& s) { s.network.loss = 1.4; }), "network.loss: 1.4 is outside [0, 1]");
  EXPECT_EQ(validate_error([](Scenario& s) { s.network.loss = -0.1; }),
            "network.loss: -0.1 is outside [0, 1]");
  EXPECT_STARTS_WITH(override_error({"network.loss=-0.1"}), "network.loss: -0.1 is outside [0, 1]");
  EXPECT_STARTS_WITH(override_error({"network.loss=1.4"}), "network.loss: 1.4 is outside [0, 1]");
  const std::string message = error_of([] { load_scenario(kFixtures + "invalid_loss.yaml"); });
  EXPECT_STARTS_WITH(message, "network.loss: 1.4 is outside [0, 1] at ");
  EXPECT_NE(message.find("invalid_loss.yaml:3:9"), std::string::npos) << message;
}

TEST(ScenarioErrors, NanIsRejectedForEveryNumericKey) {
  const std::array<std::string, 9> free_text{"name",          "world.positions_file", "world.data_dir",
                                             "dds.interface", "dds.peer_address",     "dds.security_dir",
                                             "faults.kill",   "faults.pause",         "faults.partition"};
  for (const auto& key : known_keys()) {
    if (std::find(free_text.begin(), free_text.end(), key) != free_text.end()) continue;
    EXPECT_STARTS_WITH(override_error({key + "=.nan"}), key + ": ");
  }
  EXPECT_STARTS_WITH(override_error({"network.loss=.nan"}), "network.loss: nan is not a finite number");
  EXPECT_STARTS_WITH(error_of([] { load_scenario(kFixtures + "invalid_nan.yaml"); }),
                     "noise.range_std_m: nan is not a finite number at ");
  EXPECT_EQ(validate_error([](Scenario& s) { s.qos.estimate.deadline_s = std::nan(""); }),
            "qos.estimate.deadline_s: nan is not a finite number");
  EXPECT_EQ(validate_error([](Scenario& s) { s.run.rate_hz = std::numeric_limits<double>::infinity(); }),
            "run.rate_hz: inf is not a finite number");
}

TEST(ScenarioErrors, UnknownKeyNamesTheFullPathAndSuggestsTheClosestKey) {
  const std::string message = error_of([] { load_scenario(kFixtures + "invalid_unknown_key.yaml"); });
  EXPECT_STARTS_WITH(message, "world.agnets: unknown key (did you mean world.agents?) at ");
  EXPECT_NE(message.find("invalid_unknown_key.yaml:3:3"), std::string::npos) << message;
  EXPECT_STARTS_WITH(error_of([] { parse_scenario("wrld:\n  agents: 3\n"); }),
                     "wrld: unknown key (did you mean world?)");
  EXPECT_STARTS_WITH(error_of([] { parse_scenario("qos:\n  state:\n    depth: 3\n"); }),
                     "qos.state.depth: unknown key");
  EXPECT_STARTS_WITH(override_error({"world.agnets=40"}),
                     "world.agnets: unknown key (did you mean world.agents?)");
  EXPECT_STARTS_WITH(override_error({"world.loss=0.1"}),
                     "world.loss: unknown key (did you mean network.loss?)");
  EXPECT_EQ(override_error({"completely.unrelated=1"}),
            "completely.unrelated: unknown key (from --set completely.unrelated=1)");
  EXPECT_STARTS_WITH(override_error({"qos.state=1"}), "qos.state: is a section, not a key; set one of ");
}

TEST(ScenarioErrors, TypeErrorsNameTheKeyAndQuoteTheValue) {
  EXPECT_EQ(override_error({"run.steps=abc"}),
            "run.steps: expected an integer, got 'abc' (from --set run.steps=abc)");
  EXPECT_STARTS_WITH(error_of([] { load_scenario(kFixtures + "invalid_type.yaml"); }),
                     "run.steps: expected an integer, got 'abc' at ");
  EXPECT_STARTS_WITH(override_error({"run.steps=1.5"}), "run.steps: expected an integer, got '1.5'");
  EXPECT_STARTS_WITH(override_error({"seed=-1"}), "seed: expected a non-negative integer, got '-1'");
  EXPECT_STARTS_WITH(override_error({"world.agents=99999999999"}),
                     "world.agents: 99999999999 is out of range");
  EXPECT_STARTS_WITH(override_error({"network.loss=lots"}), "network.loss: expected a number, got 'lots'");
  EXPECT_STARTS_WITH(override_error({"world.require_connected=maybe"}),
                     "world.require_connected: expected true or false, got 'maybe'");
  EXPECT_STARTS_WITH(override_error({"run.steps="}), "run.steps: expected an integer, got an empty value");
  EXPECT_STARTS_WITH(error_of([] { parse_scenario("world: 5\n"); }),
                     "world: expected a map with keys world.agents, ");
  EXPECT_STARTS_WITH(error_of([] { parse_scenario("run:\n  steps: {a: 1}\n"); }),
                     "run.steps: expected an integer, got a map");
}

TEST(ScenarioErrors, LockstepRefusesPausesAndRestartsButKeepsPlainKills) {
  EXPECT_STARTS_WITH(override_error({"run.mode=lockstep", "faults.pause=3@10-20"}),
                     "faults.pause: is not supported with run.mode = lockstep");
  EXPECT_STARTS_WITH(override_error({"run.mode=lockstep", "faults.kill=2@5,3@10-20"}),
                     "faults.kill: restarts (agent@from-to) are not supported with run.mode = lockstep");
  EXPECT_NO_THROW(parse_scenario("", {"run.mode=lockstep", "faults.kill=0@0,2@5"}));
  EXPECT_NO_THROW(parse_scenario("", {"run.mode=free_run", "faults.kill=3@10-20", "faults.pause=4@10-20"}));
}

TEST(ScenarioErrors, BadEnumListsTheAllowedValues) {
  EXPECT_STARTS_WITH(error_of([] { load_scenario(kFixtures + "invalid_enum.yaml"); }),
                     "run.mode: 'sprint' is not one of free_run|lockstep at ");
  EXPECT_STARTS_WITH(override_error({"world.placement=circle"}),
                     "world.placement: 'circle' is not one of uniform|grid|file");
  EXPECT_STARTS_WITH(override_error({"qos.control.durability=persistent"}),
                     "qos.control.durability: 'persistent' is not one of volatile|transient_local");
  EXPECT_STARTS_WITH(override_error({"qos.state.reliability=Reliable"}),
                     "qos.state.reliability: 'Reliable' is not one of best_effort|reliable");
}

TEST(ScenarioErrors, OverrideWithoutEqualsSignIsRejected) {
  EXPECT_EQ(override_error({"world.agents40"}),
            "--set 'world.agents40': expected key.path=value, e.g. --set world.agents=40");
  EXPECT_STARTS_WITH(override_error({"=40"}), "--set '=40': expected key.path=value");
  EXPECT_STARTS_WITH(override_error({""}), "--set '': expected key.path=value");
}

TEST(ScenarioErrors, YamlSyntaxErrorGivesLineAndColumn) {
  const std::string path = kFixtures + "invalid_syntax.yaml";
  const std::string message = error_of([&] { load_scenario(path); });
  EXPECT_STARTS_WITH(message, "scenario file '" + path + "': YAML syntax error at line ");
  EXPECT_NE(message.find(", column "), std::string::npos) << message;
  EXPECT_STARTS_WITH(error_of([] { parse_scenario("a: [\n", {}, "inline"); }),
                     "inline: YAML syntax error at line ");
}

TEST(ScenarioErrors, StrayCommaIsASyntaxErrorNotAnEndlessAllocation) {
  // yaml-cpp 0.7's LoadAll loops on a ',' outside a flow collection until memory runs out
  // (jbeder/yaml-cpp#1040); found by the scenario fuzz target. It must be a plain ScenarioError.
  EXPECT_EQ(error_of([] { parse_scenario(",", {}, "comma"); }),
            "comma: YAML syntax error at line 1, column 1: unexpected ','");
  EXPECT_EQ(error_of([] { parse_scenario("# text\n , world: 1\n", {}, "comma"); }),
            "comma: YAML syntax error at line 2, column 2: unexpected ','");
  EXPECT_STARTS_WITH(error_of([] { parse_scenario("seed: 3\n,\n", {}, "comma"); }),
                     "comma: YAML syntax error");
}

TEST(ScenarioErrors, DuplicateKeyIsRejected) {
  EXPECT_STARTS_WITH(error_of([] { load_scenario(kFixtures + "invalid_duplicate_key.yaml"); }),
                     "network.loss: duplicate key at ");
}

TEST(ScenarioErrors, DottedKeyInAFileIsRejected) {
  EXPECT_STARTS_WITH(error_of([] { parse_scenario("world.agents: 40\n"); }),
                     "world.agents: dotted names are for --set");
}

TEST(ScenarioErrors, TopLevelMustBeAMap) {
  EXPECT_STARTS_WITH(error_of([] { parse_scenario("- 1\n- 2\n", {}, "list.yaml"); }),
                     "list.yaml: expected a map of scenario keys at the top level, got a list");
  EXPECT_STARTS_WITH(error_of([] { parse_scenario("a: 1\n---\nb: 2\n", {}, "two.yaml"); }),
                     "two.yaml: expected one YAML document, found 2");
}

TEST(ScenarioErrors, EveryRangeRuleNamesItsKey) {
  struct Case {
    std::function<void(Scenario&)> change;
    std::string message;
  };
  const std::vector<Case> cases{
      {[](Scenario& s) { s.name.clear(); }, "name: must not be empty"},
      {[](Scenario& s) { s.algorithm.kalman.process_noise_std_m = -0.5; },
       "algorithm.process_noise_std_m: -0.5 must be >= 0"},
      {[](Scenario& s) { s.algorithm.kalman.initial_information = 0.0; },
       "algorithm.initial_information: 0 must be > 0"},
      {[](Scenario& s) { s.algorithm.kalman.initial_std_m = 0.0; }, "algorithm.initial_std_m: 0 must be > 0"},
      {[](Scenario& s) { s.algorithm.kalman.range_gate_chi2 = -1.0; },
       "algorithm.range_gate_chi2: -1 must be >= 0"},
      {[](Scenario& s) { s.world.agents = 0; }, "world.agents: 0 is outside [1, 100000]"},
      {[](Scenario& s) { s.world.agents = 100001; }, "world.agents: 100001 is outside [1, 100000]"},
      {[](Scenario& s) { s.world.anchors = -1; }, "world.anchors: -1 must be >= 0"},
      {[](Scenario& s) { s.world.area_m = 0.0; }, "world.area_m: 0 must be > 0"},
      {[](Scenario& s) { s.world.placement = Placement::kFile; },
       "world.positions_file: must be set when world.placement is file"},
      {[](Scenario& s) { s.world.motion_std_m = -1.0; }, "world.motion_std_m: -1 must be >= 0"},
      {[](Scenario& s) { s.world.initial_guess_std_m = -1.0; }, "world.initial_guess_std_m: -1 must be >= 0"},
      {[](Scenario& s) { s.noise.range_std_m = -0.1; }, "noise.range_std_m: -0.1 must be >= 0"},
      {[](Scenario& s) { s.noise.anchor_fix_std_m = -2.0; }, "noise.anchor_fix_std_m: -2 must be >= 0"},
      {[](Scenario& s) { s.clock.drift_ppm = -1.0; }, "clock.drift_ppm: -1 is outside [0, 100000]"},
      {[](Scenario& s) { s.clock.drift_ppm = 2e5; }, "clock.drift_ppm: 200000 is outside [0, 100000]"},
      {[](Scenario& s) { s.clock.offset_max_s = -1.0; }, "clock.offset_max_s: -1 must be >= 0"},
      {[](Scenario& s) { s.run.steps = 0; }, "run.steps: 0 must be >= 1"},
      {[](Scenario& s) { s.run.rate_hz = 0.0; }, "run.rate_hz: 0 is outside (0, 1000]"},
      {[](Scenario& s) { s.run.rate_hz = 1000.5; }, "run.rate_hz: 1000.5 is outside (0, 1000]"},
      {[](Scenario& s) { s.run.startup_timeout_s = 0.0; }, "run.startup_timeout_s: 0 must be > 0"},
      {[](Scenario& s) { s.run.settle_s = -1.0; }, "run.settle_s: -1 must be >= 0"},
      {[](Scenario& s) {
         s.algorithm.name = "dml";
         s.world.motion = Motion::kRandomWalk;
       },
       "world.motion: must be static for dml (it pools every range draw of the run; docs/algorithms.md §9)"},
      {[](Scenario& s) {
         s.algorithm.name = "dml";
         s.noise.anchor_fix_std_m = 0.5;
       },
       "noise.anchor_fix_std_m: must be 0 for dml (it needs exactly known anchors; docs/algorithms.md §9.7)"},
      {[](Scenario& s) {
         s.algorithm.name = "dml";
         s.noise.shared_range_draws = true;
       },
       "noise.shared_range_draws: must be false for dml (it counts each end's draws as independent; "
       "docs/algorithms.md §9.7)"},
      {[](Scenario& s) { s.run.agent_nice = -1; }, "run.agent_nice: -1 is outside [0, 19]"},
      {[](Scenario& s) { s.run.agent_nice = 20; }, "run.agent_nice: 20 is outside [0, 19]"},
      {[](Scenario& s) { s.run.agent_steps_per_world_step = 0; },
       "run.agent_steps_per_world_step: 0 is outside [1, 1000]"},
      {[](Scenario& s) { s.run.agent_steps_per_world_step = 2; },
       "run.agent_steps_per_world_step: above 1 needs an algorithm whose step without a measurement is an "
       "exchange only (jacobi, dle, joint_field, multipath_bp, dgbb, local_bb, fixed_step, step_length, "
       "dml, dml_track); 'ieif' would predict on every extra step"},
      {[](Scenario& s) {
         s.algorithm.name = "jacobi";
         s.run.agent_steps_per_world_step = 2;
         s.run.mode = RunMode::kLockstep;
       },
       "run.agent_steps_per_world_step: above 1 is not supported with run.mode = lockstep (use free_run)"},
      {[](Scenario& s) {
         s.algorithm.name = "jacobi";
         s.run.agent_steps_per_world_step = 11;
         s.run.rate_hz = 1000.0;
       },
       "run.agent_steps_per_world_step: run.rate_hz × this is above 10 kHz of agent steps"},
      {[](Scenario& s) { s.qos.measurements.history_depth = 0; },
       "qos.measurements.history_depth: 0 must be >= 1"},
      {[](Scenario& s) { s.qos.control.deadline_s = -1.0; }, "qos.control.deadline_s: -1 must be >= 0"},
      {[](Scenario& s) { s.qos.belief.liveliness_lease_s = -1.0; },
       "qos.belief.liveliness_lease_s: -1 must be >= 0"},
      {[](Scenario& s) { s.dds.domain_id = 231; }, "dds.domain_id: 231 is outside [0, 230]"},
      {[](Scenario& s) { s.dds.domain_id = -1; }, "dds.domain_id: -1 is outside [0, 230]"},
      {[](Scenario& s) { s.run.mode = static_cast<RunMode>(7); }, "run.mode: invalid enum value 7"},
  };
  for (const auto& test_case : cases) EXPECT_EQ(validate_error(test_case.change), test_case.message);
}

TEST(ScenarioErrors, BurstLengthIsZeroOrAtLeastTheBernoulliBurst) {
  EXPECT_EQ(
      parse_scenario("network:\n  loss: 0.3\n  burst:\n    mean_length: 10\n").network.burst.mean_length,
      10.0);
  EXPECT_EQ(validate_error([](Scenario& s) { s.network.burst.mean_length = 0.5; }),
            "network.burst.mean_length: 0.5 is outside [1, 1000]");
  EXPECT_EQ(validate_error([](Scenario& s) { s.network.burst.mean_length = 1001.0; }),
            "network.burst.mean_length: 1001 is outside [1, 1000]");
  EXPECT_EQ(validate_error([](Scenario& s) { s.network.burst.mean_length = -1.0; }),
            "network.burst.mean_length: -1 is outside [1, 1000]");
  EXPECT_EQ(validate_error([](Scenario& s) { s.network.burst.mean_length = std::nan(""); }),
            "network.burst.mean_length: nan is not a finite number");
  // At loss 0.6 independent drops already come in runs of 1/(1 - 0.6) = 2.5 on average.
  EXPECT_STARTS_WITH(override_error({"network.loss=0.6", "network.burst.mean_length=2"}),
                     "network.burst.mean_length: 2 is shorter than 1/(1 - network.loss) = 2.5");
  EXPECT_NE(override_error({"network.loss=0.6", "network.burst.mean_length=2"})
                .find("(from --set network.burst.mean_length=2)"),
            std::string::npos);
  EXPECT_NO_THROW(parse_scenario("", {"network.loss=0.6", "network.burst.mean_length=2.5"}));
  EXPECT_NO_THROW(parse_scenario("", {"network.loss=1", "network.burst.mean_length=1"}));
  EXPECT_NO_THROW(parse_scenario("", {"network.loss=0", "network.burst.mean_length=1000"}));
  EXPECT_STARTS_WITH(override_error({"network.burst=3"}), "network.burst: is a section, not a key");
  EXPECT_STARTS_WITH(error_of([] { parse_scenario("network:\n  burst: 3\n"); }),
                     "network.burst: expected a map with keys network.burst.mean_length");
}

TEST(ScenarioErrors, SimulatorClockAndLatencyKeysNameThemselves) {
  EXPECT_EQ(parse_scenario("", {"run.sim_clock=agents"}).run.sim_clock, SimClock::kAgents);
  EXPECT_EQ(parse_scenario("").run.sim_clock, SimClock::kRounds);
  EXPECT_EQ(parse_scenario("").run.tick_phase, TickPhase::kSpread);
  EXPECT_EQ(parse_scenario("", {"run.tick_phase=aligned"}).run.tick_phase, TickPhase::kAligned);
  EXPECT_STARTS_WITH(override_error({"run.tick_phase=late"}),
                     "run.tick_phase: 'late' is not one of spread|aligned");
  EXPECT_STARTS_WITH(override_error({"run.sim_clock=sideways"}),
                     "run.sim_clock: 'sideways' is not one of rounds|agents");
  EXPECT_EQ(validate_error([](Scenario& s) { s.run.sim_clock = static_cast<SimClock>(5); }),
            "run.sim_clock: invalid enum value 5");
  const std::string agents = "run.sim_clock=agents";
  EXPECT_STARTS_WITH(override_error({agents, "network.delay_ms=-1"}),
                     "network.delay_ms: -1 is outside [0, 10000]");
  EXPECT_STARTS_WITH(override_error({agents, "network.jitter_ms=10000.5"}),
                     "network.jitter_ms: 10000.5 is outside [0, 10000]");
  EXPECT_STARTS_WITH(override_error({agents, "network.delay_ms=.inf"}),
                     "network.delay_ms: inf is not a finite number");
  EXPECT_STARTS_WITH(override_error({agents, "network.jitter_ms=abc"}),
                     "network.jitter_ms: expected a number");
  // Latency is simulated only on agent clocks; in rounds it would silently do nothing.
  EXPECT_STARTS_WITH(override_error({"network.delay_ms=5"}),
                     "network.delay_ms: needs run.sim_clock = agents");
  EXPECT_STARTS_WITH(override_error({"network.jitter_ms=5"}),
                     "network.jitter_ms: needs run.sim_clock = agents");
  EXPECT_NO_THROW(parse_scenario("", {agents, "network.delay_ms=0", "network.jitter_ms=10000"}));
  EXPECT_NO_THROW(parse_scenario("", {agents, "network.delay_ms=10000", "network.jitter_ms=0"}));
}

TEST(ScenarioErrors, BoundaryValuesAreAccepted) {
  EXPECT_NO_THROW(parse_scenario("", {"network.loss=0", "clock.drift_ppm=100000", "run.rate_hz=1000"}));
  EXPECT_NO_THROW(parse_scenario("", {"network.loss=1", "world.anchors=30", "dds.domain_id=230"}));
  EXPECT_NO_THROW(parse_scenario("", {"world.agents=1", "world.anchors=0", "run.steps=1"}));
}

// ---------------------------------------------------------------------------------------------------
// Serialization

TEST(ScenarioYaml, RoundTripOfDefaultsIsExact) {
  const Scenario defaults;
  const std::string text = to_yaml(defaults);
  const Scenario parsed = parse_scenario(text);
  expect_scenarios_equal(parsed, defaults);
  EXPECT_EQ(to_yaml(parsed), text);
}

TEST(ScenarioYaml, RoundTripOfEveryChangedFieldIsExact) {
  Scenario free_run_faults = everything_changed();  // restarts and pauses need run.mode = free_run
  free_run_faults.run.mode = RunMode::kFreeRun;
  free_run_faults.faults = {"3@0-9, 4@0", "5@0-2", "0-0"};
  free_run_faults.run.agent_steps_per_world_step = 7;  // lockstep refuses it
  for (const Scenario& changed : {everything_changed(), free_run_faults}) {
    ASSERT_NO_THROW(validate(changed));
    const std::string text = to_yaml(changed);
    const Scenario parsed = parse_scenario(text);
    expect_scenarios_equal(parsed, changed);
    EXPECT_EQ(to_yaml(parsed), text);
  }
}

TEST(ScenarioYaml, OutputWritesEveryKnownKeyOnce) {
  const std::string text = to_yaml(Scenario{});
  for (const auto& key : known_keys()) {
    const std::string leaf = key.substr(key.rfind('.') + 1);
    EXPECT_NE(text.find(leaf + ": "), std::string::npos) << key;
  }
  EXPECT_NE(text.find("world:\n  agents: 30\n"), std::string::npos) << text;
  EXPECT_NE(text.find("qos:\n  measurements:\n    reliability: reliable\n    history_depth: 4\n"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("  area_m: 40.0\n"), std::string::npos) << text;
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), static_cast<long>(known_keys().size() + 9 + 7 + 1));
}

TEST(ScenarioYaml, HashIsFnv1aOfTheYaml) {
  const Scenario scenario;
  std::uint64_t expected = 14695981039346656037ULL;
  for (const char c : to_yaml(scenario)) {
    expected = (expected ^ static_cast<unsigned char>(c)) * 1099511628211ULL;
  }
  EXPECT_EQ(scenario_hash(scenario), expected);
}

TEST(ScenarioYaml, HashChangesWithAnyKeyAndOnlyThen) {
  const Scenario a;
  Scenario b;
  EXPECT_EQ(scenario_hash(a), scenario_hash(b));
  b.qos.control.history_depth = 5;
  EXPECT_NE(scenario_hash(a), scenario_hash(b));
  EXPECT_EQ(scenario_hash(parse_scenario(to_yaml(everything_changed()))),
            scenario_hash(everything_changed()));
}

}  // namespace
}  // namespace swarmloc::config
