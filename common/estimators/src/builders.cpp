// The agent builders (builders.hpp), one per algorithm; the registry (config/src/algorithms.cpp) names them.
#include "swarmloc/estimators/builders.hpp"

#include <memory>
#include <stdexcept>
#include <string>

#include "swarmloc/estimators/bp/multipath_bp.hpp"
#include "swarmloc/estimators/consensus/dle.hpp"
#include "swarmloc/estimators/consensus/jacobi.hpp"
#include "swarmloc/estimators/consensus/joint_field.hpp"
#include "swarmloc/estimators/dml/dml.hpp"
#include "swarmloc/estimators/dml/tracking.hpp"
#include "swarmloc/estimators/gradient/dgbb.hpp"
#include "swarmloc/estimators/kalman/ieif.hpp"
#include "swarmloc/estimators/kalman/iekf.hpp"
#include "swarmloc/estimators/pose/dead_reckoning.hpp"
#include "swarmloc/estimators/pose/pose_ekf.hpp"
#include "swarmloc/estimators/pose/pose_ieif.hpp"
#include "swarmloc/estimators/pose/team_pose_ekf.hpp"

namespace swarmloc::estimators::builders {
namespace {

using gradient::StepRule;

template <typename Algorithm>
std::unique_ptr<Estimator> kalman_filter(const AgentSetup& setup, const EstimatorParams& params) {
  return std::make_unique<Algorithm>(setup, params.kalman);
}

/// The gradient family: one class, the step rule fixed by the algorithm (its `rule` is overridden).
std::unique_ptr<Estimator> gradient_descent(const AgentSetup& setup, const EstimatorParams& params,
                                            StepRule rule) {
  gradient::DgBbParams gradient = params.gradient;
  gradient.rule = rule;
  return std::make_unique<gradient::DgBb>(setup, gradient);
}

}  // namespace

// docs/algorithms.md §3.2, §3.5
std::unique_ptr<Estimator> ieif(const AgentSetup& setup, const EstimatorParams& params) {
  return kalman_filter<Ieif>(setup, params);
}
std::unique_ptr<Estimator> iekf(const AgentSetup& setup, const EstimatorParams& params) {
  return kalman_filter<Iekf>(setup, params);
}
// docs/algorithms.md §9, §9.8 (moving worlds)
std::unique_ptr<Estimator> dml(const AgentSetup& setup, const EstimatorParams& params) {
  if (setup.dimensions == 3) return kalman_filter<DmlT<3>>(setup, params);
  if (setup.dimensions == 2) return kalman_filter<DmlT<2>>(setup, params);
  throw std::invalid_argument("dml: world.dimensions must be 2 or 3, not " +
                              std::to_string(setup.dimensions));
}
std::unique_ptr<Estimator> dml_track(const AgentSetup& setup, const EstimatorParams& params) {
  if (setup.dimensions != 2)
    throw std::invalid_argument("dml_track: planar worlds only (world.dimensions: 2)");
  return kalman_filter<DmlTracking>(setup, params);
}
// pose states (x, y, θ), estimators/pose/pose_ekf.hpp; its information form; odometry only (baseline)
std::unique_ptr<Estimator> pose_ekf(const AgentSetup& setup, const EstimatorParams& params) {
  return kalman_filter<PoseEkf>(setup, params);
}
std::unique_ptr<Estimator> pose_ieif(const AgentSetup& setup, const EstimatorParams& params) {
  return kalman_filter<PoseIeif>(setup, params);
}
std::unique_ptr<Estimator> team_pose_ekf(const AgentSetup& setup, const EstimatorParams& params) {
  return kalman_filter<TeamPoseEkf>(setup, params);
}
std::unique_ptr<Estimator> dead_reckoning(const AgentSetup& setup, const EstimatorParams& params) {
  return kalman_filter<DeadReckoning>(setup, params);
}
// Atanasov et al. eq. (9), Alg. 1, eq. (10)
std::unique_ptr<Estimator> jacobi(const AgentSetup& setup, const EstimatorParams& /*params*/) {
  return std::make_unique<consensus::JacobiLocalization>(setup);
}
std::unique_ptr<Estimator> dle(const AgentSetup& setup, const EstimatorParams& params) {
  return std::make_unique<consensus::Dle>(setup, params.consensus.dle);
}
std::unique_ptr<Estimator> joint_field(const AgentSetup& setup, const EstimatorParams& params) {
  return std::make_unique<consensus::JointLocalizationField>(setup, params.consensus.joint_field);
}
// Leng et al. Alg. 1
std::unique_ptr<Estimator> multipath_bp(const AgentSetup& setup, const EstimatorParams& params) {
  return std::make_unique<bp::MultipathBp>(setup, params.bp);
}
// Calafiore et al. Alg. 1, and its Sec. V-B baselines
std::unique_ptr<Estimator> dgbb(const AgentSetup& setup, const EstimatorParams& params) {
  return gradient_descent(setup, params, StepRule::kConsensusBb);
}
std::unique_ptr<Estimator> local_bb(const AgentSetup& setup, const EstimatorParams& params) {
  return gradient_descent(setup, params, StepRule::kLocalBb);
}
std::unique_ptr<Estimator> fixed_step(const AgentSetup& setup, const EstimatorParams& params) {
  return gradient_descent(setup, params, StepRule::kFixed);
}
std::unique_ptr<Estimator> step_length(const AgentSetup& setup, const EstimatorParams& params) {
  return gradient_descent(setup, params, StepRule::kStepLength);
}

}  // namespace swarmloc::estimators::builders
