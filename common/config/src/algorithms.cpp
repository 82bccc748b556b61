// The algorithm registry (algorithms.hpp): one entry per algorithm, and each family's own scenario rules.
#include "swarmloc/config/algorithms.hpp"

#include <stdexcept>
#include <string>

#include "scenario_keys.hpp"
#include "swarmloc/config/scenario.hpp"

namespace swarmloc::config {
namespace {

using enum AlgorithmFamily;
using enum RangeDraws;
using enum AnchorData;

[[noreturn]] void reject_key(std::string_view path, const std::string& message) {
  throw ScenarioError(std::string(path) + ": " + message);
}

void validate_dml(const Scenario& s) {
  if (s.world.motion != Motion::kStatic) {
    reject_key("world.motion",
               "must be static for dml (it pools every range draw of the run; docs/algorithms.md §9)");
  }
  if (s.noise.anchor_fix_std_m > 0.0) {
    reject_key("noise.anchor_fix_std_m",
               "must be 0 for dml (it needs exactly known anchors; docs/algorithms.md §9.7)");
  }
  if (s.noise.shared_range_draws) {
    reject_key("noise.shared_range_draws",
               "must be false for dml (it counts each end's draws as independent; docs/algorithms.md §9.7)");
  }
}

void validate_dml_track(const Scenario& s) {
  if (s.noise.shared_range_draws) {
    reject_key("noise.shared_range_draws",
               "must be false for dml_track (it counts each end's draw of a step "
               "as independent; docs/algorithms.md §9.8)");
  }
}

void require_relative_information(const Scenario& s, std::string_view name) {
  if (!(s.noise.relative_std_m > 0.0)) {
    reject_key("noise.relative_std_m", "must be > 0 for " + std::string(name) +
                                           " (its measurement information is 1/relative_std_m²)");
  }
}

void validate_jacobi(const Scenario& s) { require_relative_information(s, "jacobi"); }

void validate_dle(const Scenario& s) {
  if (s.world.motion != Motion::kStatic) {
    reject_key("world.motion", "must be static for dle (its sensors use their known, fixed positions)");
  }
  if (!(s.noise.target_std_m > 0.0)) {
    reject_key("noise.target_std_m", "must be > 0 for dle (its reading information is 1/target_std_m²)");
  }
}

void validate_joint_field(const Scenario& s) {
  if (s.world.motion != Motion::kStatic) {
    reject_key("world.motion", "must be static for joint_field (Jacobi localizes static sensors)");
  }
  if (!(s.noise.field_std > 0.0)) {
    reject_key("noise.field_std", "must be > 0 for joint_field (its reading information is 1/field_std²)");
  }
  require_relative_information(s, "joint_field");
}

void validate_multipath_bp(const Scenario& s) {
  if (s.world.wall_count < 1) {
    reject_key("world.wall_count",
               "multipath_bp needs at least one reflecting wall (it uses reflected paths only)");
  }
  if (!(s.noise.range_std_m > 0.0)) {
    reject_key("noise.range_std_m",
               "must be > 0 for multipath_bp (its path-length variance is range_std_m²)");
  }
}

// Measurement kinds.
constexpr MeasurementKinds kRangesAndFixes{.ranges = true, .anchor_fixes = true};
constexpr MeasurementKinds kRangesOnly{.ranges = true};  // anchors know their position (AgentSetup)
constexpr MeasurementKinds kRelative{.relative = true};
constexpr MeasurementKinds kTargets{.targets = true};
constexpr MeasurementKinds kRelativeAndField{.relative = true, .field = true};
constexpr MeasurementKinds kPaths{.paths = true};

// Bound data, read off each algorithm's code: ieif/iekf anchors run no filter and publish their known
// position, each agent updates with its own ranges only (docs/algorithms.md §3.1); the fusion centre takes
// one range per edge and every anchor's fix (sim/centralized_runner.cpp centralized_measurements); dml pools
// both ends' draws; the gradient family's anchors are known and each agent uses its own ranges (newest per
// neighbour); relative positions and path lengths are one draw per link shared by both ends.
constexpr BoundSpec kOwnRanges{BoundModel::kRanges, kOwnDraws, kKnown, {}};
constexpr BoundSpec kFusionRanges{BoundModel::kRanges, kOnePerEdge, kFixes, {}};
constexpr BoundSpec kPooledRanges{BoundModel::kRanges, kAllDraws, kFixes, {}};
constexpr BoundSpec kScenarioBound{BoundModel::kScenario, kAllDraws, kKnown, {}};
constexpr BoundSpec kPoseNone{BoundModel::kNone, kAllDraws, kKnown,
                              "pose-state filter (range-bearing and odometry model): no bound implemented"};
constexpr BoundSpec kOdometryNone{BoundModel::kNone, kAllDraws, kKnown,
                                  "odometry only: no bound implemented"};

// Parameter blocks read, off each builder: the Kalman filters their block; the fusion centre its
// process noise and prior std (sim/centralized_runner.cpp); dle its prior information (runtime/
// agent_factory.cpp); dml and jacobi none.
constexpr ParamBlocks kKalmanKeys{.kalman = true};
constexpr ParamBlocks kPoseKeys{.kalman = true, .pose = true};
constexpr ParamBlocks kGradientKeys{.gradient = true};
constexpr ParamBlocks kFieldKeys{.field = true};
constexpr ParamBlocks kMultipathKeys{.multipath = true};
constexpr ParamBlocks kNoKeys{};

// Sample families each estimator's outbox fills (tests/unit/sim/test_algorithm_registry.cpp checks them
// against what a run publishes).
constexpr MessageFamilies kNoMessages{};
constexpr MessageFamilies kStateMessages{.state = true};
constexpr MessageFamilies kStateAndInformation{.state = true, .information = true};
constexpr MessageFamilies kStateAndConsensus{.state = true, .consensus = true};
constexpr MessageFamilies kBeliefMessages{.belief = true};
constexpr MessageFamilies kObservationMessages{.observations = true};

constexpr AlgorithmPlacement kAgent = AlgorithmPlacement::kAgent;
constexpr AlgorithmPlacement kCentre = AlgorithmPlacement::kFusionCentre;

// Builders (estimators/builders.hpp).
namespace builders = estimators::builders;
using estimators::centralized::CentralizedKind;
constexpr estimators::EstimatorBuilder agent_build(estimators::AgentBuilder build) {
  return estimators::agent_builder(build);
}
constexpr estimators::EstimatorBuilder fusion_build(CentralizedKind kind, bool relabel) {
  return estimators::fusion_builder(kind, relabel);
}

}  // namespace

const std::vector<AlgorithmSpec>& algorithm_registry() {
  // name, family, placement, kinds, bound, exchange_only, validate, parameter blocks, messages, builder
  static const std::vector<AlgorithmSpec> registry{
      {"ieif", kKalman, kAgent, kRangesAndFixes, kOwnRanges, false, nullptr, kKalmanKeys, kStateMessages,
       agent_build(&builders::ieif)},  // docs/algorithms.md §3.2
      {"iekf", kKalman, kAgent, kRangesAndFixes, kOwnRanges, false, nullptr, kKalmanKeys, kStateMessages,
       agent_build(&builders::iekf)},  // docs/algorithms.md §3.5
      {"ekf", kCentralized, kCentre, kRangesAndFixes, kFusionRanges, false, nullptr, kKalmanKeys, kNoMessages,
       fusion_build(CentralizedKind::kEkf, false), true},
      {"lbekf", kCentralized, kCentre, kRangesAndFixes, kFusionRanges, false, nullptr, kKalmanKeys,
       kNoMessages, fusion_build(CentralizedKind::kLbEkf, false), true},
      {"lbekf_vr", kCentralized, kCentre, kRangesAndFixes, kFusionRanges, false, nullptr, kKalmanKeys,
       kNoMessages, fusion_build(CentralizedKind::kLbEkf, true), true},
      {"lbekf_i", kCentralized, kCentre, kRangesAndFixes, kFusionRanges, false, nullptr, kKalmanKeys,
       kNoMessages, fusion_build(CentralizedKind::kLbEkfI, true), true},
      {"jacobi", kConsensus, kAgent, kRelative, kScenarioBound, true, &validate_jacobi, kNoKeys,
       kStateMessages, agent_build(&builders::jacobi)},  // Atanasov et al. (9)
      {"dle", kConsensus, kAgent, kTargets, kScenarioBound, true, &validate_dle, kKalmanKeys,
       kStateAndInformation, agent_build(&builders::dle)},  // Atanasov et al. Alg. 1
      {"joint_field", kConsensus, kAgent, kRelativeAndField, kScenarioBound, true, &validate_joint_field,
       kFieldKeys, kStateAndInformation, agent_build(&builders::joint_field)},
      {"multipath_bp", kBp, kAgent, kPaths, kScenarioBound, true, &validate_multipath_bp, kMultipathKeys,
       kBeliefMessages, agent_build(&builders::multipath_bp)},  // Leng et al. Alg. 1
      {"dgbb", kGradient, kAgent, kRangesOnly, kOwnRanges, true, nullptr, kGradientKeys, kStateAndConsensus,
       agent_build(&builders::dgbb)},  // Calafiore et al. Alg. 1
      {"local_bb", kGradient, kAgent, kRangesOnly, kOwnRanges, true, nullptr, kGradientKeys, kStateMessages,
       agent_build(&builders::local_bb)},
      {"fixed_step", kGradient, kAgent, kRangesOnly, kOwnRanges, true, nullptr, kGradientKeys, kStateMessages,
       agent_build(&builders::fixed_step)},
      {"step_length", kGradient, kAgent, kRangesOnly, kOwnRanges, true, nullptr, kGradientKeys,
       kStateMessages, agent_build(&builders::step_length)},
      {"pose_ekf", kPose, kAgent, kRangesAndFixes, kPoseNone, false, nullptr, kPoseKeys, kStateMessages,
       agent_build(&builders::pose_ekf)},
      {"pose_ieif", kPose, kAgent, kRangesAndFixes, kPoseNone, false, nullptr, kPoseKeys, kStateMessages,
       agent_build(&builders::pose_ieif)},
      // docs/algorithms.md §10: the team's joint filter at every robot, from shared observations.
      {"team_pose_ekf", kPose, kAgent, kRangesAndFixes, kPoseNone, false, nullptr, kPoseKeys,
       kObservationMessages, agent_build(&builders::team_pose_ekf)},
      {"dead_reckoning", kPose, kAgent, kRangesAndFixes, kOdometryNone, false, nullptr, kPoseKeys,
       kStateMessages, agent_build(&builders::dead_reckoning)},
      // docs/algorithms.md §9; a step without a batch is one more sweep (docs/algorithms.md §9.2).
      {"dml", kDml, kAgent, kRangesAndFixes, kPooledRanges, true, &validate_dml, kNoKeys, kStateMessages,
       agent_build(&builders::dml), true},
      // docs/algorithms.md §9.8; reads process_noise_std_m and initial_std_m; a step without a batch
      // iterates its window again.
      {"dml_track", kDml, kAgent, kRangesAndFixes, kPooledRanges, true, &validate_dml_track, kKalmanKeys,
       kBeliefMessages, agent_build(&builders::dml_track)},
  };
  return registry;
}

const std::vector<ParamBlockSpec>& param_blocks() {
  using enum ParamBlock;
  static const std::vector<ParamBlockSpec> blocks{
      {kKalman, "kalman", &detail::validate_kalman_params},
      {kPose, "pose", &detail::validate_pose_params},
      {kGradient, "gradient", &detail::validate_gradient_params},
      {kField, "field", &detail::validate_field_params},
      {kMultipath, "multipath", &detail::validate_multipath_params},
  };
  return blocks;
}

const ParamBlockSpec& param_block_spec(ParamBlock block) {
  for (const auto& spec : param_blocks()) {
    if (spec.block == block) return spec;
  }
  throw std::logic_error("param_block_spec: a block without an entry");
}

std::string algorithms_reading(ParamBlock block) {
  std::string list;
  for (const auto& spec : algorithm_registry()) {
    if (spec.blocks.reads(block)) list += (list.empty() ? "" : ", ") + std::string(spec.name);
  }
  return list;
}

const AlgorithmSpec* find_algorithm(std::string_view name) {
  for (const auto& spec : algorithm_registry()) {
    if (spec.name == name) return &spec;
  }
  return nullptr;
}

std::string known_algorithm_list() {
  std::string list;
  for (const auto& spec : algorithm_registry()) list += (list.empty() ? "" : ", ") + std::string(spec.name);
  return list;
}

const AlgorithmSpec& algorithm_spec(std::string_view name) {
  if (const AlgorithmSpec* spec = find_algorithm(name)) return *spec;
  reject_key("algorithm.name",
             "'" + std::string(name) + "' is not a known algorithm (known: " + known_algorithm_list() + ")");
}

std::vector<std::string> agent_algorithms() {
  std::vector<std::string> names;
  for (const auto& spec : algorithm_registry()) {
    if (spec.build.agent != nullptr) names.emplace_back(spec.name);
  }
  return names;
}

std::unique_ptr<estimators::Estimator> make_estimator(std::string_view name,
                                                      const estimators::AgentSetup& setup,
                                                      const estimators::EstimatorParams& params) {
  const AlgorithmSpec* spec = find_algorithm(name);
  if (spec != nullptr && spec->build.agent != nullptr) return spec->build.agent(setup, params);
  std::string known;
  for (const auto& agent_name : agent_algorithms()) known += (known.empty() ? "" : ", ") + agent_name;
  throw std::invalid_argument("estimator algorithm '" + std::string(name) +
                              "' is not an agent's; known: " + known);
}

bool runs_in_fusion_centre(std::string_view name) {
  const AlgorithmSpec* spec = find_algorithm(name);
  return spec != nullptr && spec->placement == AlgorithmPlacement::kFusionCentre;
}

}  // namespace swarmloc::config
