#pragma once
// Factory for the cooperative (consensus / BP / gradient) estimators of Atanasov et al., Leng et al. and
// Calafiore et al.: the CooperativeParams view of the registry's builders (registry.hpp).
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

/// "jacobi" (Atanasov et al. eq. (9)), "dle" (Atanasov et al. Alg. 1), "joint_field" (Atanasov et al. eq.
/// (10)), "multipath_bp" (Leng et al. Alg. 1), "dgbb" (Calafiore et al. Alg. 1), "local_bb", "fixed_step",
/// "step_length" (Calafiore et al. Sec. V-B baselines). Throws std::invalid_argument for an unknown name (the
/// message lists the known ones).
std::unique_ptr<Estimator> make_cooperative_estimator(const std::string& algorithm, const AgentSetup& setup,
                                                      const CooperativeParams& params);

/// Names accepted by make_cooperative_estimator.
const std::vector<std::string>& cooperative_algorithms();

}  // namespace swarmloc::estimators
