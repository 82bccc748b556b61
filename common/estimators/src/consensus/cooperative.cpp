#include "swarmloc/estimators/consensus/cooperative.hpp"

#include <stdexcept>

#include "swarmloc/estimators/consensus/jacobi.hpp"

namespace swarmloc::estimators {

const std::vector<std::string>& cooperative_algorithms() {
  static const std::vector<std::string> names{"jacobi", "dle",      "joint_field", "multipath_bp",
                                              "dgbb",   "local_bb", "fixed_step",  "step_length"};
  return names;
}

std::unique_ptr<Estimator> make_cooperative_estimator(const std::string& algorithm, const AgentSetup& setup,
                                                      const CooperativeParams& params) {
  if (algorithm == "jacobi") return std::make_unique<consensus::JacobiLocalization>(setup);
  if (algorithm == "dle") return std::make_unique<consensus::Dle>(setup, params.dle);
  if (algorithm == "joint_field")
    return std::make_unique<consensus::JointLocalizationField>(setup, params.joint_field);
  if (algorithm == "multipath_bp") return std::make_unique<bp::MultipathBp>(setup, params.bp);
  gradient::DgBbParams gradient = params.gradient;
  if (algorithm == "dgbb") {
    gradient.rule = gradient::StepRule::kConsensusBb;
  } else if (algorithm == "local_bb") {
    gradient.rule = gradient::StepRule::kLocalBb;
  } else if (algorithm == "fixed_step") {
    gradient.rule = gradient::StepRule::kFixed;
  } else if (algorithm == "step_length") {
    gradient.rule = gradient::StepRule::kStepLength;
  } else {
    std::string known;
    for (const auto& name : cooperative_algorithms()) known += (known.empty() ? "" : ", ") + name;
    throw std::invalid_argument("cooperative estimator '" + algorithm + "' is unknown; known: " + known);
  }
  return std::make_unique<gradient::DgBb>(setup, gradient);
}

}  // namespace swarmloc::estimators
