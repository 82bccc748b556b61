#pragma once
// The builders of the algorithm registry (config/algorithms.hpp holds what each algorithm is, where it
// runs and what data it needs; config cannot name estimator types, so the builders live here, one per
// registry entry, and tests/unit/sim/test_algorithm_registry.cpp keeps the two tables equal).
// make_estimator (estimator.hpp) and make_cooperative_estimator (consensus/cooperative.hpp) are views of
// this table, one per parameter block.
#include <memory>
#include <optional>
#include <string_view>
#include <vector>

#include "swarmloc/estimators/centralized/centralized_filter.hpp"
#include "swarmloc/estimators/consensus/cooperative.hpp"
#include "swarmloc/estimators/estimator.hpp"

namespace swarmloc::estimators {

/// The parameter block an algorithm's builder reads. runtime/agent_factory.cpp fills each from the
/// scenario's own blocks (config's ParamBlock): kKalman from kalman and pose, kCooperative from gradient,
/// field, multipath and (dle) kalman.initial_information.
enum class ParamBlock {
  kKalman,       ///< KalmanFamilyParams (the Kalman, dml and pose families)
  kCooperative,  ///< CooperativeParams (the consensus, BP and gradient families)
  kFusion,       ///< the fusion centre's CentralizedFilterParams; agents are sensors only
};

/// Every block, for the builders.
struct EstimatorParams {
  KalmanFamilyParams kalman;
  CooperativeParams cooperative;
};

/// How one algorithm is built.
struct EstimatorBuilder {
  std::string_view name;
  ParamBlock params = ParamBlock::kKalman;
  /// The agent's estimator (block kKalman or kCooperative); null for kFusion.
  std::unique_ptr<Estimator> (*agent)(const AgentSetup&, const EstimatorParams&) = nullptr;
  /// kFusion: the fusion centre's filter and whether it relabels the agents once at start-up (Khan et al.
  /// Alg. 3 with ).
  std::optional<centralized::CentralizedKind> fusion;
  bool relabel = false;
};

/// Every builder.
const std::vector<EstimatorBuilder>& estimator_builders();

/// The builder of `name`, or nullptr.
const EstimatorBuilder* find_estimator_builder(std::string_view name);

/// The names whose builder reads `block`, in table order ("a, b, …" when joined for messages).
std::vector<std::string> builder_names(ParamBlock block);

}  // namespace swarmloc::estimators
