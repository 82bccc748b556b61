#pragma once
// Estimators by their registry name for the tests (the registry, config/algorithms.hpp, holds each
// algorithm's builder): the Kalman-block families' and the cooperative families' names and builders.
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/estimators/params.hpp"

namespace swarmloc::testing {

/// The registry's names whose family is one of `families`, in registry order.
inline std::vector<std::string> algorithms_of(std::initializer_list<config::AlgorithmFamily> families) {
  std::vector<std::string> names;
  for (const auto& spec : config::algorithm_registry()) {
    for (const config::AlgorithmFamily family : families)
      if (spec.family == family) names.emplace_back(spec.name);
  }
  return names;
}

/// The algorithms that read KalmanFilterParams: the Kalman, dml and pose families.
inline std::vector<std::string> kalman_block_algorithms() {
  using enum config::AlgorithmFamily;
  return algorithms_of({kKalman, kDml, kPose});
}

/// The cooperative families: consensus, BP and gradient.
inline std::vector<std::string> cooperative_algorithms() {
  using enum config::AlgorithmFamily;
  return algorithms_of({kConsensus, kBp, kGradient});
}

/// The registry's estimator `name` with `kalman` and every other block at its defaults.
inline std::unique_ptr<estimators::Estimator> make_named_estimator(
    std::string_view name, const estimators::AgentSetup& setup,
    const estimators::KalmanFilterParams& kalman) {
  estimators::EstimatorParams params;
  params.kalman = kalman;
  return config::make_estimator(name, setup, params);
}

}  // namespace swarmloc::testing
