#pragma once
// How each algorithm is built: one builder per algorithm. The algorithm registry (config/algorithms.hpp,
// one entry per algorithm) holds each algorithm's builder beside what it is, where it runs and what data it
// needs; make_estimator in config builds an agent's estimator by name from it. Nothing here knows the names.
#include <memory>
#include <optional>

#include "swarmloc/estimators/centralized/centralized_filter.hpp"
#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/params.hpp"

namespace swarmloc::estimators {

/// An agent's estimator from every family's parameters (it reads its own family's block).
using AgentBuilder = std::unique_ptr<Estimator> (*)(const AgentSetup&, const EstimatorParams&);

/// How one algorithm is built: an agent's estimator, or (placed in the fusion centre) the fusion centre's
/// filter, whose agents are sensors only.
struct EstimatorBuilder {
  AgentBuilder agent = nullptr;
  /// The fusion centre's filter and whether it relabels the agents once at start-up (Khan et al. Alg. 3
  /// with ).
  std::optional<centralized::CentralizedKind> fusion;
  bool relabel = false;
};

constexpr EstimatorBuilder agent_builder(AgentBuilder agent) {
  return EstimatorBuilder{agent, std::nullopt, false};
}
constexpr EstimatorBuilder fusion_builder(centralized::CentralizedKind kind, bool relabel) {
  return EstimatorBuilder{nullptr, kind, relabel};
}

/// The agent builders, one per algorithm.
namespace builders {
std::unique_ptr<Estimator> ieif(const AgentSetup& setup, const EstimatorParams& params);
std::unique_ptr<Estimator> iekf(const AgentSetup& setup, const EstimatorParams& params);
std::unique_ptr<Estimator> dml(const AgentSetup& setup, const EstimatorParams& params);
std::unique_ptr<Estimator> dml_track(const AgentSetup& setup, const EstimatorParams& params);
std::unique_ptr<Estimator> pose_ekf(const AgentSetup& setup, const EstimatorParams& params);
std::unique_ptr<Estimator> pose_ieif(const AgentSetup& setup, const EstimatorParams& params);
std::unique_ptr<Estimator> team_pose_ekf(const AgentSetup& setup, const EstimatorParams& params);
std::unique_ptr<Estimator> dead_reckoning(const AgentSetup& setup, const EstimatorParams& params);
std::unique_ptr<Estimator> jacobi(const AgentSetup& setup, const EstimatorParams& params);
std::unique_ptr<Estimator> dle(const AgentSetup& setup, const EstimatorParams& params);
std::unique_ptr<Estimator> joint_field(const AgentSetup& setup, const EstimatorParams& params);
std::unique_ptr<Estimator> multipath_bp(const AgentSetup& setup, const EstimatorParams& params);
std::unique_ptr<Estimator> dgbb(const AgentSetup& setup, const EstimatorParams& params);
std::unique_ptr<Estimator> local_bb(const AgentSetup& setup, const EstimatorParams& params);
std::unique_ptr<Estimator> fixed_step(const AgentSetup& setup, const EstimatorParams& params);
std::unique_ptr<Estimator> step_length(const AgentSetup& setup, const EstimatorParams& params);
}  // namespace builders

}  // namespace swarmloc::estimators
