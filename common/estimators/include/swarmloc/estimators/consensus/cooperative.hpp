#pragma once
// Factory for the cooperative (consensus / BP / gradient) estimators of 002, 003 and 004: the
// CooperativeParams view of the registry's builders (registry.hpp).
#include <memory>
#include <string>
#include <vector>

#include "swarmloc/estimators/bp/multipath_bp.hpp"
#include "swarmloc/estimators/consensus/dle.hpp"
#include "swarmloc/estimators/consensus/joint_field.hpp"
#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/gradient/dgbb.hpp"

namespace swarmloc::estimators {

struct CooperativeParams {
  consensus::DleParams dle;
  consensus::JointFieldParams joint_field;
  bp::MultipathBpParams bp;
  gradient::DgBbParams gradient;  ///< its `rule` is overridden by the algorithm name
};

/// "jacobi" (002 eq. (9)), "dle" (002 Alg. 1), "joint_field" (002 eq. (10)), "multipath_bp" (003 Alg. 1),
/// "dgbb" (004 Alg. 1), "local_bb", "fixed_step", "step_length" (004 Sec. V-B baselines). Throws
/// std::invalid_argument for an unknown name (the message lists the known ones).
std::unique_ptr<Estimator> make_cooperative_estimator(const std::string& algorithm, const AgentSetup& setup,
                                                      const CooperativeParams& params);

/// Names accepted by make_cooperative_estimator.
const std::vector<std::string>& cooperative_algorithms();

}  // namespace swarmloc::estimators
