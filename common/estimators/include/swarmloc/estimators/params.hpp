#pragma once
// Every family's parameters, one block each (each block's struct lives beside its family); an algorithm's
// builder (builders.hpp) reads its own family's block only.
#include "swarmloc/estimators/bp/params.hpp"
#include "swarmloc/estimators/consensus/params.hpp"
#include "swarmloc/estimators/gradient/params.hpp"
#include "swarmloc/estimators/kalman/params.hpp"

namespace swarmloc::estimators {

struct EstimatorParams {
  KalmanFilterParams kalman;  ///< the Kalman, dml and pose families
  consensus::ConsensusParams consensus;
  bp::MultipathBpParams bp;
  gradient::DgBbParams gradient;  ///< its `rule` is overridden by the algorithm
};

}  // namespace swarmloc::estimators
