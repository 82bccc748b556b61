#pragma once
// The algorithm registry: one entry per algorithm that `run` and `sim` execute, saying what it is (name,
// family), where it runs (every agent, or one fusion centre), which data the world generates for it, what
// data its bound is computed from (docs/algorithms.md §1.3.1) and which scenario keys it additionally
// requires, which parameter blocks of Scenario::Algorithm it reads, and how it is built (its builder,
// estimators/builders.hpp). Every layer that asks about an algorithm asks this table; none tests a name
// itself. tests/unit/sim/test_algorithm_registry.cpp checks that every entry has exactly one builder and
// every builder exactly one entry.
//
// Adding an algorithm: its estimator class in its family's folder, its builder function in
// estimators/builders.hpp, one entry here (its keys in an existing parameter block, or a new block in
// scenario.hpp with its keys in config/src/scenario_keys.cpp and its ranges in config/src/validate.cpp),
// and its tests.
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "swarmloc/estimators/builders.hpp"

namespace swarmloc::config {

struct Scenario;

/// The family, which fixes the parameter block an algorithm reads and how its agent step behaves.
enum class AlgorithmFamily {
  kKalman,       ///< distributed Kalman filters over ranges (ieif, iekf; docs/algorithms.md §3)
  kDml,          ///< distributed maximum likelihood over every pooled range draw (docs/algorithms.md §9)
  kCentralized,  ///< one filter over the whole network in the fusion centre (ekf, lbekf…; docs/algorithms.md
                 ///< §2.7)
  kPose,       ///< pose-state filters over range-bearing and odometry data (MRCLAM)
  kConsensus,  ///< consensus localization / tracking (jacobi, dle, joint_field; Atanasov et al.)
  kBp,         ///< belief propagation over reflected paths (multipath_bp; Leng et al.)
  kGradient,   ///< distributed gradient descent over ranges (dgbb and its baselines; Calafiore et al.)
};

/// The parameter blocks of Scenario::Algorithm (scenario.hpp), one per family that has knobs.
enum class ParamBlock { kKalman, kPose, kGradient, kField, kMultipath };

/// The blocks an algorithm reads; a key of any other block is reported as not used by it.
struct ParamBlocks {
  bool kalman = false;
  bool pose = false;
  bool gradient = false;
  bool field = false;
  bool multipath = false;
  [[nodiscard]] constexpr bool reads(ParamBlock block) const {
    switch (block) {
      case ParamBlock::kKalman:
        return kalman;
      case ParamBlock::kPose:
        return pose;
      case ParamBlock::kGradient:
        return gradient;
      case ParamBlock::kField:
        return field;
      case ParamBlock::kMultipath:
        return multipath;
    }
    return false;
  }
};

/// One parameter block: its name in messages and its ranges. Every block is validated whatever the
/// algorithm, so whether a file is accepted does not depend on algorithm.name.
struct ParamBlockSpec {
  ParamBlock block = ParamBlock::kKalman;
  std::string_view name;  ///< "gradient"
  /// Each key's range; throws ScenarioError naming the key ("algorithm.fixed_step: 0 must be > 0").
  void (*validate)(const Scenario&) = nullptr;
};

/// Every block.
const std::vector<ParamBlockSpec>& param_blocks();

/// The entry of `block`.
const ParamBlockSpec& param_block_spec(ParamBlock block);

/// Where an algorithm's estimator runs.
enum class AlgorithmPlacement {
  kAgent,         ///< in every agent
  kFusionCentre,  ///< in one fusion centre fed with the agents' measurement batches; agents are sensors
};

/// What the world measures for an algorithm: ranges (+ anchor fixes) for the Kalman and gradient
/// families, relative positions for jacobi (Atanasov et al. eq. (3)), reflected paths for multipath_bp (Leng
/// et al. eq. (1)), target readings for dle (Atanasov et al. eqs. (2), (4)), relative positions and field
/// readings for joint_field (Atanasov et al. eqs. (3), (10)).
struct MeasurementKinds {
  bool ranges = false;
  bool anchor_fixes = false;
  bool relative = false;
  bool paths = false;
  bool targets = false;
  bool field = false;
};

/// Which range draws an algorithm's estimates are built from.
enum class RangeDraws {
  kAllDraws,    ///< both ends' draws of every edge (shared draws: the edge's one draw)
  kOnePerEdge,  ///< one draw per edge (a fusion centre taking one endpoint's range)
  kOwnDraws,    ///< each non-anchor agent's own draws (anchors run no filter, their draws go unused)
};
/// What the algorithm knows about the anchors.
enum class AnchorData {
  kKnown,  ///< exactly known positions (AgentSetup): anchors are not in θ
  kFixes,  ///< anchors are in θ and send a fix per step (noise.anchor_fix_std_m; exact when it is 0)
};
/// Which bound applies to an algorithm's measurements.
enum class BoundModel {
  kRanges,    ///< range draws and anchor data as declared: world/bound.cpp computes it
  kScenario,  ///< relative positions, paths or a target: scenario_crlb's bound (static truth only)
  kNone,      ///< no bound implemented for the measurement model
};

/// The data an algorithm's bound is computed from (docs/algorithms.md §1.3.1), read off its code.
struct BoundSpec {
  BoundModel model = BoundModel::kNone;
  RangeDraws draws = RangeDraws::kAllDraws;
  AnchorData anchors = AnchorData::kKnown;
  std::string_view none_reason;  ///< model kNone: why
};

/// The inter-agent sample families an algorithm's agents publish and read (docs/design.md §3). The DDS
/// agent creates a writer and a reader for these only: Cyclone announces every endpoint to every peer,
/// so an unused one costs discovery traffic at start-up (docs/scale.md, "Endpoints, hellos and
/// heartbeats").
struct MessageFamilies {
  bool state = false;
  bool information = false;
  bool consensus = false;
  bool belief = false;
  bool observations = false;  ///< uses qos.state
};

/// One algorithm.
struct AlgorithmSpec {
  std::string_view name;
  AlgorithmFamily family = AlgorithmFamily::kKalman;
  AlgorithmPlacement placement = AlgorithmPlacement::kAgent;
  MeasurementKinds kinds;
  BoundSpec bound;
  /// Its agent step without a measurement is an exchange only (no prediction), so it may take
  /// run.agent_steps_per_world_step > 1.
  bool exchange_only = false;
  /// The algorithm's own scenario rules (beyond every key's range); throws ScenarioError. May be null.
  void (*validate)(const Scenario&) = nullptr;
  /// The parameter blocks its builder reads (runtime/agent_factory.cpp, the fusion centre).
  ParamBlocks blocks;
  /// What its agents exchange (none: a fusion-centre algorithm's agents only sense).
  MessageFamilies messages;
  /// How it is built (estimators/builders.hpp): an agent's estimator, or the fusion centre's filter.
  estimators::EstimatorBuilder build;
  /// It runs in 3-D worlds too (world.dimensions: 3).
  bool three_dimensional = false;
};

/// Every entry, in the order `known algorithms` lists them.
const std::vector<AlgorithmSpec>& algorithm_registry();

/// The entry of `name`, or nullptr.
const AlgorithmSpec* find_algorithm(std::string_view name);

/// The entry of `name`; throws ScenarioError ("algorithm.name: 'x' is not a known algorithm (known: …)").
const AlgorithmSpec& algorithm_spec(std::string_view name);

/// True if `name` is an entry placed in the fusion centre.
bool runs_in_fusion_centre(std::string_view name);

/// "ieif, iekf, …": the registry's names for messages.
std::string known_algorithm_list();

/// "dgbb, local_bb, …": the entries that read `block`.
std::string algorithms_reading(ParamBlock block);

/// The names of the entries an agent runs (those with an agent builder), in registry order.
std::vector<std::string> agent_algorithms();

/// Builds agent `setup`'s estimator for the entry `name` from every family's parameters. Throws
/// std::invalid_argument for a name that is not an agent's algorithm (the message lists those).
std::unique_ptr<estimators::Estimator> make_estimator(std::string_view name,
                                                      const estimators::AgentSetup& setup,
                                                      const estimators::EstimatorParams& params);

}  // namespace swarmloc::config
