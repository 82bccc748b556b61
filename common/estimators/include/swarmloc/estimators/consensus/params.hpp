#pragma once
// The consensus family's parameters (Atanasov et al.): DLE's and the joint field's; Jacobi has none.
#include "swarmloc/estimators/consensus/dle.hpp"
#include "swarmloc/estimators/consensus/joint_field.hpp"

namespace swarmloc::estimators::consensus {

struct ConsensusParams {
  DleParams dle;
  JointFieldParams joint_field;
};

}  // namespace swarmloc::estimators::consensus
