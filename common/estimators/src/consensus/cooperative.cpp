// make_cooperative_estimator: the CooperativeParams view of the registry's builders (registry.hpp).
#include "swarmloc/estimators/consensus/cooperative.hpp"

#include <stdexcept>

#include "swarmloc/estimators/registry.hpp"

namespace swarmloc::estimators {

const std::vector<std::string>& cooperative_algorithms() {
  static const std::vector<std::string> names = builder_names(ParamBlock::kCooperative);
  return names;
}

std::unique_ptr<Estimator> make_cooperative_estimator(const std::string& algorithm, const AgentSetup& setup,
                                                      const CooperativeParams& params) {
  const EstimatorBuilder* builder = find_estimator_builder(algorithm);
  if (builder != nullptr && builder->params == ParamBlock::kCooperative) {
    EstimatorParams all;
    all.cooperative = params;
    return builder->agent(setup, all);
  }
  std::string known;
  for (const auto& name : cooperative_algorithms()) known += (known.empty() ? "" : ", ") + name;
  throw std::invalid_argument("cooperative estimator '" + algorithm + "' is unknown; known: " + known);
}

}  // namespace swarmloc::estimators
