// The builders of the algorithm registry (registry.hpp) and make_estimator, their Kalman-block view. To
// add an algorithm, add one builder here beside its config/algorithms.cpp entry.
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "swarmloc/estimators/consensus/jacobi.hpp"
#include "swarmloc/estimators/dml/dml.hpp"
#include "swarmloc/estimators/dml/tracking.hpp"
#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/kalman/ieif.hpp"
#include "swarmloc/estimators/kalman/iekf.hpp"
#include "swarmloc/estimators/pose/dead_reckoning.hpp"
#include "swarmloc/estimators/pose/pose_ekf.hpp"
#include "swarmloc/estimators/pose/pose_ieif.hpp"
#include "swarmloc/estimators/registry.hpp"

namespace swarmloc::estimators {
namespace {

using centralized::CentralizedKind;
using gradient::StepRule;

template <typename Algorithm>
std::unique_ptr<Estimator> kalman(const AgentSetup& setup, const EstimatorParams& params) {
  return std::make_unique<Algorithm>(setup, params.kalman);
}

std::unique_ptr<Estimator> jacobi(const AgentSetup& setup, const EstimatorParams& /*params*/) {
  return std::make_unique<consensus::JacobiLocalization>(setup);
}

std::unique_ptr<Estimator> dle(const AgentSetup& setup, const EstimatorParams& params) {
  return std::make_unique<consensus::Dle>(setup, params.cooperative.dle);
}

std::unique_ptr<Estimator> joint_field(const AgentSetup& setup, const EstimatorParams& params) {
  return std::make_unique<consensus::JointLocalizationField>(setup, params.cooperative.joint_field);
}

std::unique_ptr<Estimator> multipath_bp(const AgentSetup& setup, const EstimatorParams& params) {
  return std::make_unique<bp::MultipathBp>(setup, params.cooperative.bp);
}

/// The gradient family: one class, the step rule fixed by the algorithm (its `rule` is overridden).
template <StepRule rule>
std::unique_ptr<Estimator> gradient_descent(const AgentSetup& setup, const EstimatorParams& params) {
  gradient::DgBbParams gradient = params.cooperative.gradient;
  gradient.rule = rule;
  return std::make_unique<gradient::DgBb>(setup, gradient);
}

using enum ParamBlock;

const std::vector<EstimatorBuilder>& builders() {
  static const std::vector<EstimatorBuilder> table{
      {"ieif", kKalman, &kalman<Ieif>, {}, false},              // docs/algorithms.md §3.2
      {"iekf", kKalman, &kalman<Iekf>, {}, false},              // docs/algorithms.md §3.5
      {"dml", kKalman, &kalman<Dml>, {}, false},                // docs/algorithms.md §9
      {"dml_track", kKalman, &kalman<DmlTracking>, {}, false},  // §9.8: moving worlds
      {"pose_ekf", kKalman, &kalman<PoseEkf>, {}, false},       // pose states (x, y, θ), pose/pose_ekf.hpp
      {"pose_ieif", kKalman, &kalman<PoseIeif>, {}, false},     // its information form
      {"dead_reckoning", kKalman, &kalman<DeadReckoning>, {}, false},  // odometry only (baseline)
      {"jacobi", kCooperative, &jacobi, {}, false},                    // Atanasov et al. eq. (9)
      {"dle", kCooperative, &dle, {}, false},                          // Atanasov et al. Alg. 1
      {"joint_field", kCooperative, &joint_field, {}, false},          // Atanasov et al. eq. (10)
      {"multipath_bp", kCooperative, &multipath_bp, {}, false},        // Leng et al. Alg. 1
      // Calafiore et al. Alg. 1, and its Sec. V-B baselines:
      {"dgbb", kCooperative, &gradient_descent<StepRule::kConsensusBb>, {}, false},
      {"local_bb", kCooperative, &gradient_descent<StepRule::kLocalBb>, {}, false},
      {"fixed_step", kCooperative, &gradient_descent<StepRule::kFixed>, {}, false},
      {"step_length", kCooperative, &gradient_descent<StepRule::kStepLength>, {}, false},
      {"ekf", kFusion, nullptr, CentralizedKind::kEkf, false},  // Khan et al.
      {"lbekf", kFusion, nullptr, CentralizedKind::kLbEkf, false},
      {"lbekf_vr", kFusion, nullptr, CentralizedKind::kLbEkf, true},
      {"lbekf_i", kFusion, nullptr, CentralizedKind::kLbEkfI, true},
  };
  return table;
}

}  // namespace

const std::vector<EstimatorBuilder>& estimator_builders() { return builders(); }

const EstimatorBuilder* find_estimator_builder(std::string_view name) {
  for (const auto& builder : builders()) {
    if (builder.name == name) return &builder;
  }
  return nullptr;
}

std::vector<std::string> builder_names(ParamBlock block) {
  std::vector<std::string> names;
  for (const auto& builder : builders()) {
    if (builder.params == block) names.emplace_back(builder.name);
  }
  return names;
}

const std::vector<std::string>& known_algorithms() {
  static const std::vector<std::string> names = builder_names(kKalman);
  return names;
}

std::unique_ptr<Estimator> make_estimator(const std::string& algorithm, const AgentSetup& setup,
                                          const KalmanFamilyParams& params) {
  const EstimatorBuilder* builder = find_estimator_builder(algorithm);
  if (builder != nullptr && builder->params == kKalman) {
    EstimatorParams all;
    all.kalman = params;
    return builder->agent(setup, all);
  }
  std::string known;
  for (const auto& name : known_algorithms()) known += (known.empty() ? "" : ", ") + name;
  throw std::invalid_argument("estimator algorithm '" + algorithm + "' is unknown; known: " + known);
}

}  // namespace swarmloc::estimators
