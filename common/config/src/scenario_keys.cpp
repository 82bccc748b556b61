// The key table and the scalar codecs (see scenario_keys.hpp).
#include "scenario_keys.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <concepts>
#include <cstdio>
#include <iterator>
#include <limits>
#include <system_error>
#include <type_traits>
#include <utility>

#include "swarmloc/config/algorithms.hpp"

namespace swarmloc::config::detail {
namespace {

// ---------------------------------------------------------------------------------------------------
// Enum names: lowercase snake case in files; a hyphenated spelling ("free-run") is accepted on input.

template <typename E>
using EnumNames = std::array<std::pair<E, std::string_view>, 2>;

constexpr std::array<std::pair<Placement, std::string_view>, 3> kPlacementNames{
    {{Placement::kUniform, "uniform"}, {Placement::kGrid, "grid"}, {Placement::kFile, "file"}}};
constexpr EnumNames<WorldSource> kWorldSourceNames{
    {{WorldSource::kGenerated, "generated"}, {WorldSource::kMrclam, "mrclam"}}};
constexpr EnumNames<Motion> kMotionNames{{{Motion::kStatic, "static"}, {Motion::kRandomWalk, "random_walk"}}};
constexpr EnumNames<TargetMotion> kTargetMotionNames{
    {{TargetMotion::kStatic, "static"}, {TargetMotion::kDoubleIntegrator, "double_integrator"}}};
constexpr EnumNames<TargetSensing> kTargetSensingNames{
    {{TargetSensing::kLinear, "linear"}, {TargetSensing::kRangeBearing, "range_bearing"}}};
constexpr EnumNames<FieldSensing> kFieldSensingNames{
    {{FieldSensing::kContinuous, "continuous"}, {FieldSensing::kCellBased, "cell_based"}}};
constexpr EnumNames<RunMode> kRunModeNames{
    {{RunMode::kFreeRun, "free_run"}, {RunMode::kLockstep, "lockstep"}}};
constexpr EnumNames<SimClock> kSimClockNames{{{SimClock::kRounds, "rounds"}, {SimClock::kAgents, "agents"}}};
constexpr EnumNames<TickPhase> kTickPhaseNames{
    {{TickPhase::kSpread, "spread"}, {TickPhase::kAligned, "aligned"}}};
constexpr EnumNames<InitialGuess> kInitialGuessNames{
    {{InitialGuess::kNoisyTruth, "noisy_truth"}, {InitialGuess::kUniform, "uniform"}}};
constexpr EnumNames<LocalBbDifference> kLocalBbDifferenceNames{
    {{LocalBbDifference::kGradientChange, "gradient_change"}, {LocalBbDifference::kOwnMove, "own_move"}}};
constexpr EnumNames<PathVariance> kPathVarianceNames{
    {{PathVariance::kRangeOnly, "range_only"}, {PathVariance::kWithDoa, "with_doa"}}};
constexpr EnumNames<BpMessages> kBpMessagesNames{
    {{BpMessages::kBeliefs, "beliefs"}, {BpMessages::kExact, "exact"}}};
constexpr EnumNames<Reliability> kReliabilityNames{
    {{Reliability::kBestEffort, "best_effort"}, {Reliability::kReliable, "reliable"}}};
constexpr EnumNames<Durability> kDurabilityNames{
    {{Durability::kVolatile, "volatile"}, {Durability::kTransientLocal, "transient_local"}}};

constexpr std::array<std::pair<RangeNoise, std::string_view>, 3> kRangeNoiseNames{
    {{RangeNoise::kAdditive, "additive"},
     {RangeNoise::kProportional, "proportional"},
     {RangeNoise::kAffine, "affine"}}};
constexpr EnumNames<NoiseDraw> kNoiseDrawNames{
    {{NoiseDraw::kPerStep, "per_step"}, {NoiseDraw::kOnce, "once"}}};

const auto& names_of(Placement /*tag*/) { return kPlacementNames; }
const auto& names_of(WorldSource /*tag*/) { return kWorldSourceNames; }
const auto& names_of(Motion /*tag*/) { return kMotionNames; }
const auto& names_of(TargetMotion /*tag*/) { return kTargetMotionNames; }
const auto& names_of(TargetSensing /*tag*/) { return kTargetSensingNames; }
const auto& names_of(FieldSensing /*tag*/) { return kFieldSensingNames; }
const auto& names_of(RunMode /*tag*/) { return kRunModeNames; }
const auto& names_of(SimClock /*tag*/) { return kSimClockNames; }
const auto& names_of(TickPhase /*tag*/) { return kTickPhaseNames; }
const auto& names_of(InitialGuess /*tag*/) { return kInitialGuessNames; }
const auto& names_of(LocalBbDifference /*tag*/) { return kLocalBbDifferenceNames; }
const auto& names_of(PathVariance /*tag*/) { return kPathVarianceNames; }
const auto& names_of(BpMessages /*tag*/) { return kBpMessagesNames; }
const auto& names_of(Reliability /*tag*/) { return kReliabilityNames; }
const auto& names_of(Durability /*tag*/) { return kDurabilityNames; }
const auto& names_of(RangeNoise /*tag*/) { return kRangeNoiseNames; }
const auto& names_of(NoiseDraw /*tag*/) { return kNoiseDrawNames; }

// ---------------------------------------------------------------------------------------------------
// Decoding: every failure names the key path and quotes what was found.

std::string_view trim(std::string_view text) {
  constexpr std::string_view kSpace = " \t\r\n";
  const auto first = text.find_first_not_of(kSpace);
  if (first == std::string_view::npos) return {};
  const auto last = text.find_last_not_of(kSpace);
  return text.substr(first, last - first + 1);
}

[[noreturn]] void type_error(const std::string& path, std::string_view expected, const YAML::Node& node) {
  throw ScenarioError(path + ": expected " + std::string(expected) + ", got " + describe(node));
}

template <typename I>
requires(std::integral<I> && !std::same_as<I, bool>) void decode(const YAML::Node& node,
                                                                 const std::string& path, I& out) {
  constexpr std::string_view kWhat = std::is_signed_v<I> ? "an integer" : "a non-negative integer";
  if (!node.IsScalar()) type_error(path, kWhat, node);
  std::string_view text = trim(node.Scalar());
  if (text.size() > 1 && text.front() == '+' && text[1] != '-' && text[1] != '+') text.remove_prefix(1);
  const char* const end = text.data() + text.size();
  I value{};
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (ec == std::errc::result_out_of_range && ptr == end) {
    throw ScenarioError(path + ": " + std::string(text) + " is out of range [" +
                        std::to_string(std::numeric_limits<I>::min()) + ", " +
                        std::to_string(std::numeric_limits<I>::max()) + "]");
  }
  if (text.empty() || ec != std::errc{} || ptr != end) type_error(path, kWhat, node);
  out = value;
}

void decode(const YAML::Node& node, const std::string& path, double& out) {
  if (!node.IsScalar()) type_error(path, "a number", node);
  std::string_view text = trim(node.Scalar());
  // YAML 1.2 core-schema spellings of the special values.
  if (text == ".nan" || text == ".NaN" || text == ".NAN") {
    out = std::numeric_limits<double>::quiet_NaN();
    return;
  }
  bool negative = false;
  std::string_view body = text;
  if (!body.empty() && (body.front() == '+' || body.front() == '-')) {
    negative = body.front() == '-';
    body.remove_prefix(1);
  }
  if (body == ".inf" || body == ".Inf" || body == ".INF") {
    out = negative ? -std::numeric_limits<double>::infinity() : std::numeric_limits<double>::infinity();
    return;
  }
  if (body.empty() || body.front() == '+' || body.front() == '-') type_error(path, "a number", node);
  const char* const end = body.data() + body.size();
  double value = 0.0;
  const auto [ptr, ec] = std::from_chars(body.data(), end, value);
  if (ec == std::errc::result_out_of_range && ptr == end) {
    throw ScenarioError(path + ": " + std::string(text) + " is out of the range of a double");
  }
  if (ec != std::errc{} || ptr != end) type_error(path, "a number", node);
  out = negative ? -value : value;
}

void decode(const YAML::Node& node, const std::string& path, bool& out) {
  // The spellings yaml-cpp itself accepts for booleans.
  static constexpr std::array<std::string_view, 9> kTrue{"true", "True", "TRUE", "yes", "Yes",
                                                         "YES",  "on",   "On",   "ON"};
  static constexpr std::array<std::string_view, 9> kFalse{"false", "False", "FALSE", "no", "No",
                                                          "NO",    "off",   "Off",   "OFF"};
  if (node.IsScalar()) {
    const std::string_view text = trim(node.Scalar());
    if (std::find(kTrue.begin(), kTrue.end(), text) != kTrue.end()) {
      out = true;
      return;
    }
    if (std::find(kFalse.begin(), kFalse.end(), text) != kFalse.end()) {
      out = false;
      return;
    }
  }
  type_error(path, "true or false", node);
}

void decode(const YAML::Node& node, const std::string& path, std::string& out) {
  if (node.IsNull()) {
    out.clear();  // "positions_file:" with nothing after it means "none"
    return;
  }
  if (!node.IsScalar()) type_error(path, "a string", node);
  out = node.Scalar();
}

template <typename E>
requires std::is_enum_v<E>
void decode(const YAML::Node& node, const std::string& path, E& out) {
  const auto& names = names_of(E{});
  std::string choices;
  for (const auto& [value, name] : names) {
    if (!choices.empty()) choices += '|';
    choices += name;
  }
  if (!node.IsScalar()) type_error(path, "one of " + choices, node);
  std::string text(trim(node.Scalar()));
  std::replace(text.begin(), text.end(), '-', '_');
  for (const auto& [value, name] : names) {
    if (text == name) {
      out = value;
      return;
    }
  }
  throw ScenarioError(path + ": '" + node.Scalar() + "' is not one of " + choices);
}

// ---------------------------------------------------------------------------------------------------
// Encoding: YAML scalars that decode back to the same value.

std::string encode(int value) { return std::to_string(value); }
std::string encode(std::uint64_t value) { return std::to_string(value); }
std::string encode(bool value) { return value ? "true" : "false"; }

std::string encode(double value) {
  if (std::isnan(value)) return ".nan";
  if (std::isinf(value)) return value > 0 ? ".inf" : "-.inf";
  std::string text = format_number(value);
  // "40" -> "40.0" so the file shows which keys are real-valued.
  if (text.find_first_not_of("-0123456789") == std::string::npos) text += ".0";
  return text;
}

std::string encode(const std::string& value) {
  // Always double-quoted: "null", "true", "8", "a: b" and "" stay strings.
  std::string out = "\"";
  for (const char c : value) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      case '\r':
        out += "\\r";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
          std::array<char, 8> buffer{};
          std::snprintf(buffer.data(), buffer.size(), "\\x%02x", static_cast<unsigned>(c));
          out += buffer.data();
        } else {
          out += c;
        }
    }
  }
  out += '"';
  return out;
}

template <typename E>
requires std::is_enum_v<E> std::string encode(E value) {
  for (const auto& [candidate, name] : names_of(E{})) {
    if (candidate == value) return std::string(name);
  }
  return "invalid_" + std::to_string(static_cast<int>(value));  // only reachable by casting an int
}

// ---------------------------------------------------------------------------------------------------
// The table.

template <typename Access>
KeySpec make_key(std::string path, Access access) {
  KeySpec spec;
  spec.path = path;
  spec.read = [path, access](Scenario& scenario, const YAML::Node& node) {
    decode(node, path, access(scenario));
  };
  spec.write = [access](const Scenario& scenario) { return encode(access(scenario)); };
  return spec;
}

template <typename Family>
void add_qos_keys(std::vector<KeySpec>& keys, const std::string& family, Family access) {
  const std::string prefix = "qos." + family + ".";
  keys.push_back(make_key(
      prefix + "reliability", [access](auto& scenario) -> auto& { return access(scenario).reliability; }));
  keys.push_back(make_key(
      prefix + "history_depth", [access](auto& scenario) -> auto& {
        return access(scenario).history_depth;
      }));
  keys.push_back(make_key(
      prefix + "durability", [access](auto& scenario) -> auto& { return access(scenario).durability; }));
  keys.push_back(make_key(
      prefix + "deadline_s", [access](auto& scenario) -> auto& { return access(scenario).deadline_s; }));
  keys.push_back(make_key(
      prefix + "liveliness_lease_s", [access](auto& scenario) -> auto& {
        return access(scenario).liveliness_lease_s;
      }));
}

// The key path is the member path spelt out, so key names cannot drift from the struct.
#define SWARMLOC_KEY(member) \
  make_key(                  \
      #member, [](auto& scenario) -> auto& { return scenario.member; })
#define SWARMLOC_QOS(family) \
  add_qos_keys(              \
      keys, #family, [](auto& scenario) -> auto& { return scenario.qos.family; })

void append(std::vector<KeySpec>& keys, std::vector<KeySpec> more) {
  keys.insert(keys.end(), std::make_move_iterator(more.begin()), std::make_move_iterator(more.end()));
}

/// An algorithm knob: the key is algorithm.<member>, the member lives in the block (scenario.hpp).
template <typename Access>
KeySpec make_algorithm_key(std::string path, ParamBlock block, Access access) {
  KeySpec spec = make_key(std::move(path), access);
  spec.block = block;
  return spec;
}

// The key path is algorithm.<member>, flat as in the file; the member is found in its block.
#define SWARMLOC_ALGORITHM_KEY(block, kind, member) \
  make_algorithm_key(                               \
      "algorithm." #member, ParamBlock::kind,       \
      [](auto& scenario) -> auto& { return scenario.algorithm.block.member; })

std::vector<KeySpec> algorithm_keys() {
  return {
      SWARMLOC_KEY(algorithm.name),
      SWARMLOC_ALGORITHM_KEY(kalman, kKalman, process_noise_std_m),
      SWARMLOC_ALGORITHM_KEY(kalman, kKalman, initial_information),
      SWARMLOC_ALGORITHM_KEY(kalman, kKalman, initial_std_m),
      SWARMLOC_ALGORITHM_KEY(kalman, kKalman, inflate_stale),
      SWARMLOC_ALGORITHM_KEY(gradient, kGradient, consensus_rounds),
      SWARMLOC_ALGORITHM_KEY(gradient, kGradient, fixed_step),
      SWARMLOC_ALGORITHM_KEY(gradient, kGradient, step_length),
      SWARMLOC_ALGORITHM_KEY(gradient, kGradient, max_step),
      SWARMLOC_ALGORITHM_KEY(gradient, kGradient, max_move_fraction),
      SWARMLOC_ALGORITHM_KEY(gradient, kGradient, abs_tol),
      SWARMLOC_ALGORITHM_KEY(kalman, kKalman, range_gate_chi2),
      SWARMLOC_ALGORITHM_KEY(kalman, kKalman, update_iterations),
      SWARMLOC_ALGORITHM_KEY(pose, kPose, initial_heading_std_rad),
      SWARMLOC_ALGORITHM_KEY(pose, kPose, range_bearing_gate_chi2),
      SWARMLOC_ALGORITHM_KEY(pose, kPose, team_share_spans),
      SWARMLOC_ALGORITHM_KEY(pose, kPose, team_wait_steps),
      SWARMLOC_ALGORITHM_KEY(field, kField, field_warmup_steps),
      SWARMLOC_ALGORITHM_KEY(gradient, kGradient, local_bb_difference),
      SWARMLOC_ALGORITHM_KEY(multipath, kMultipath, path_variance),
      SWARMLOC_ALGORITHM_KEY(multipath, kMultipath, bp_messages),
  };
}

#undef SWARMLOC_ALGORITHM_KEY

std::vector<KeySpec> world_keys() {
  return {
      SWARMLOC_KEY(world.agents),
      SWARMLOC_KEY(world.anchors),
      SWARMLOC_KEY(world.area_m),
      SWARMLOC_KEY(world.dimensions),
      SWARMLOC_KEY(world.height_m),
      SWARMLOC_KEY(world.comm_radius_m),
      SWARMLOC_KEY(world.placement),
      SWARMLOC_KEY(world.positions_file),
      SWARMLOC_KEY(world.motion),
      SWARMLOC_KEY(world.motion_std_m),
      SWARMLOC_KEY(world.initial_guess),
      SWARMLOC_KEY(world.initial_guess_std_m),
      SWARMLOC_KEY(world.require_connected),
      SWARMLOC_KEY(world.require_localizable),
      SWARMLOC_KEY(world.wall_count),
      SWARMLOC_KEY(world.wall_first_angle_deg),
      SWARMLOC_KEY(world.wall_angle_step_deg),
      SWARMLOC_KEY(world.wall_margin_m),
      SWARMLOC_KEY(world.target_motion),
      SWARMLOC_KEY(world.target_x_m),
      SWARMLOC_KEY(world.target_y_m),
      SWARMLOC_KEY(world.target_vx_mps),
      SWARMLOC_KEY(world.target_vy_mps),
      SWARMLOC_KEY(world.target_accel_psd),
      SWARMLOC_KEY(world.target_sensing),
      SWARMLOC_KEY(world.target_sensing_radius_m),
      SWARMLOC_KEY(world.field_cells_per_side),
      SWARMLOC_KEY(world.field_std),
      SWARMLOC_KEY(world.field_correlation_m),
      SWARMLOC_KEY(world.field_sensing),
      SWARMLOC_KEY(world.field_sensing_radius_m),
      SWARMLOC_KEY(world.source),
      SWARMLOC_KEY(world.data_dir),
      SWARMLOC_KEY(world.data_step_s),
  };
}

std::vector<KeySpec> noise_keys() {
  return {
      SWARMLOC_KEY(noise.range_std_m),
      SWARMLOC_KEY(noise.anchor_fix_std_m),
      SWARMLOC_KEY(noise.range_model),
      SWARMLOC_KEY(noise.range_factor),
      SWARMLOC_KEY(noise.shared_range_draws),
      SWARMLOC_KEY(noise.relative_std_m),
      SWARMLOC_KEY(noise.doa_error_deg),
      SWARMLOC_KEY(noise.target_std_m),
      SWARMLOC_KEY(noise.target_bearing_std_rad),
      SWARMLOC_KEY(noise.field_std),
      SWARMLOC_KEY(noise.bearing_std_rad),
      SWARMLOC_KEY(noise.odometry_v_std),
      SWARMLOC_KEY(noise.odometry_omega_std),
      SWARMLOC_KEY(noise.odometry_lag_s),
      SWARMLOC_KEY(noise.sighting_correlation_time_s),
      SWARMLOC_KEY(noise.sighting_cluster_radius_m),
      SWARMLOC_KEY(noise.range_bias_m),
      SWARMLOC_KEY(noise.range_bias_per_rad),
      SWARMLOC_KEY(noise.range_bias_per_rad2),
      SWARMLOC_KEY(noise.robot_range_bias_m),
      SWARMLOC_KEY(noise.range_correlated_fraction),
      SWARMLOC_KEY(noise.bearing_correlated_fraction),
      SWARMLOC_KEY(noise.draw),
  };
}

std::vector<KeySpec> network_clock_and_run_keys() {
  return {
      SWARMLOC_KEY(network.loss),     SWARMLOC_KEY(network.burst.mean_length),
      SWARMLOC_KEY(network.delay_ms), SWARMLOC_KEY(network.jitter_ms),
      SWARMLOC_KEY(clock.drift_ppm),  SWARMLOC_KEY(clock.offset_max_s),
      SWARMLOC_KEY(run.steps),        SWARMLOC_KEY(run.rate_hz),
      SWARMLOC_KEY(run.mode),         SWARMLOC_KEY(run.startup_timeout_s),
      SWARMLOC_KEY(run.settle_s),     SWARMLOC_KEY(run.agent_nice),
      SWARMLOC_KEY(run.sim_clock),    SWARMLOC_KEY(run.agent_steps_per_world_step),
      SWARMLOC_KEY(run.tick_phase),
  };
}

void add_all_qos_keys(std::vector<KeySpec>& keys) {
  SWARMLOC_QOS(measurements);
  SWARMLOC_QOS(state);
  SWARMLOC_QOS(information);
  SWARMLOC_QOS(consensus);
  SWARMLOC_QOS(belief);
  SWARMLOC_QOS(estimate);
  SWARMLOC_QOS(control);
}

void add_fault_and_dds_keys(std::vector<KeySpec>& keys) {
  keys.push_back(SWARMLOC_KEY(faults.kill));
  keys.push_back(SWARMLOC_KEY(faults.pause));
  keys.push_back(SWARMLOC_KEY(faults.partition));
  keys.push_back(SWARMLOC_KEY(dds.domain_id));
  keys.push_back(SWARMLOC_KEY(dds.interface));
  keys.push_back(SWARMLOC_KEY(dds.neighbour_discovery));
  keys.push_back(SWARMLOC_KEY(dds.peer_address));
  keys.push_back(SWARMLOC_KEY(dds.security_dir));
  keys.push_back(SWARMLOC_KEY(dds.run_id));
  keys.push_back(SWARMLOC_KEY(dds.ros2));
}

/// Every key in document order (to_yaml and known_keys follow it): the top-level keys, then each section.
std::vector<KeySpec> build_key_specs() {
  std::vector<KeySpec> keys{
      SWARMLOC_KEY(seed),
      SWARMLOC_KEY(name),
  };
  append(keys, algorithm_keys());
  append(keys, world_keys());
  append(keys, noise_keys());
  append(keys, network_clock_and_run_keys());
  add_all_qos_keys(keys);
  add_fault_and_dds_keys(keys);
  return keys;
}

#undef SWARMLOC_QOS
#undef SWARMLOC_KEY

std::string_view last_component(std::string_view path) {
  const auto dot = path.rfind('.');
  return dot == std::string_view::npos ? path : path.substr(dot + 1);
}

std::string_view parent_of(std::string_view path) {
  const auto dot = path.rfind('.');
  return dot == std::string_view::npos ? std::string_view{} : path.substr(0, dot);
}

/// How far a spelling may be from a known name to be suggested.
std::size_t tolerance(std::string_view name) { return std::max<std::size_t>(1, name.size() / 3); }

}  // namespace

std::string describe(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Scalar:
      return "'" + node.Scalar() + "'";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Map:
      return "a map";
    case YAML::NodeType::Null:
      return "an empty value";
    case YAML::NodeType::Undefined:
      break;
  }
  return "nothing";
}

const std::vector<KeySpec>& key_specs() {
  static const std::vector<KeySpec> keys = build_key_specs();
  return keys;
}

const KeySpec* find_key(std::string_view path) {
  const auto& keys = key_specs();
  const auto it =
      std::find_if(keys.begin(), keys.end(), [&](const KeySpec& key) { return key.path == path; });
  return it == keys.end() ? nullptr : &*it;
}

bool is_section(std::string_view path) {
  if (path.empty()) return true;
  return std::any_of(key_specs().begin(), key_specs().end(), [&](const KeySpec& key) {
    return key.path.size() > path.size() && key.path.starts_with(path) && key.path[path.size()] == '.';
  });
}

std::vector<std::string> children_of(std::string_view section) {
  std::vector<std::string> children;
  for (const auto& key : key_specs()) {
    std::string_view rest = key.path;
    if (!section.empty()) {
      if (!(rest.size() > section.size() && rest.starts_with(section) && rest[section.size()] == '.'))
        continue;
      rest.remove_prefix(section.size() + 1);
    }
    std::string child(rest.substr(0, rest.find('.')));
    if (std::find(children.begin(), children.end(), child) == children.end()) children.push_back(child);
  }
  return children;
}

std::string suggestion_for(std::string_view path) {
  const std::string_view parent = parent_of(path);
  const std::string_view name = last_component(path);
  const auto join = [&](std::string_view child) {
    return parent.empty() ? std::string(child) : std::string(parent) + "." + std::string(child);
  };
  // 1. A sibling with a close spelling: world.agnets -> world.agents.
  if (is_section(parent)) {
    std::string best;
    std::size_t best_distance = tolerance(name) + 1;
    for (const auto& child : children_of(parent)) {
      const std::size_t distance = edit_distance(name, child);
      if (distance < best_distance) {
        best_distance = distance;
        best = child;
      }
    }
    if (!best.empty()) return " (did you mean " + join(best) + "?)";
  }
  // 2. A key with a close full path: wrld.agents -> world.agents.
  {
    std::string best;
    std::size_t best_distance = tolerance(path) + 1;
    for (const auto& key : key_specs()) {
      const std::size_t distance = edit_distance(path, key.path);
      if (distance < best_distance) {
        best_distance = distance;
        best = key.path;
      }
    }
    if (!best.empty()) return " (did you mean " + best + "?)";
  }
  // 3. The same name in another section: world.loss -> network.loss.
  std::string same_name;
  for (const auto& key : key_specs()) {
    if (last_component(key.path) == name) same_name += (same_name.empty() ? "" : " or ") + key.path;
  }
  if (!same_name.empty()) return " (did you mean " + same_name + "?)";
  return {};
}

std::string format_number(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  std::array<char, 64> buffer{};
  // Plain decimals for everyday magnitudes ("100000", not "1e+05"), exponents outside them.
  const double magnitude = std::fabs(value);
  const bool plain = magnitude == 0.0 || (magnitude >= 1e-4 && magnitude < 1e15);
  const auto result =
      plain ? std::to_chars(buffer.data(), buffer.data() + buffer.size(), value, std::chars_format::fixed)
            : std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  return std::string(buffer.data(), result.ptr);
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  // Optimal string alignment: insertions, deletions, substitutions and adjacent transpositions cost 1.
  std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1, 0));
  for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) {
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
      }
    }
  }
  return d[a.size()][b.size()];
}

}  // namespace swarmloc::config::detail

namespace swarmloc::config {

const std::vector<std::string>& exchange_only_algorithms() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const auto& spec : algorithm_registry()) {
      if (spec.exchange_only) out.emplace_back(spec.name);
    }
    return out;
  }();
  return names;
}

}  // namespace swarmloc::config
