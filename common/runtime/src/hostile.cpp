#include "swarmloc/runtime/hostile.hpp"

#include <algorithm>
#include <limits>

namespace swarmloc::runtime {

namespace {

const double kNan = std::numeric_limits<double>::quiet_NaN();

void garble_state(estimators::StateMessage& state, int variant) {
  state.mean_m = Vec2(20.0, 20.0);
  state.covariance = Mat2::Identity() * 0.01;
  if (variant == 0) state.mean_m.x() = kNan;
  if (variant == 1) state.covariance << 1.0, 5.0, 5.0, 1.0;  // eigenvalues 6 and −4
  if (variant == 2) state.mean_m = Vec2(1e12, -1e12);
  if (state.altitude) {  // 3-D: the fault moves to the z part, which its own checks must catch
    state.mean_m = Vec2(20.0, 20.0);
    state.covariance = Mat2::Identity() * 0.01;
    state.altitude = Altitude{20.0, 0.01, Vec2::Zero()};
    if (variant == 0) state.altitude->z_m = kNan;
    if (variant == 1) state.altitude->cross_m2 = Vec2(0.05, 0.0);  // each 2x2 block PSD, the 3x3 not
    if (variant == 2) state.altitude->z_m = 1e12;
  }
}

void garble_belief(estimators::BeliefMessage& belief, int variant) {
  belief.infinite_information = false;
  belief.information = Mat2::Identity();
  if (!belief.contributions.empty() && variant != 1) {
    // Exact GaBP: a belief that is well formed itself, with broken contributions.
    for (auto& contribution : belief.contributions) {
      if (variant == 0) contribution.info_vec.x() = kNan;
      if (variant == 2) contribution.information = Mat2::Identity() * 1e300;
    }
  } else {
    if (variant == 0) belief.mean_m.x() = kNan;
    if (variant == 1) belief.information << 1.0, 5.0, 5.0, 1.0;
    if (variant == 2) belief.mean_m = Vec2(1e12, -1e12);
  }
}

void garble_consensus(std::vector<estimators::ConsensusMessage>& messages, int variant) {
  for (auto& consensus : messages) {
    for (double& value : consensus.values) value = variant == 0 ? kNan : (variant == 1 ? -1e300 : 1e300);
  }
}

void garble_information(estimators::InformationMessage& information, int variant) {
  if (variant == 0) information.info_vec.setConstant(kNan);
  if (variant == 1 && information.info_mat.size() > 0) information.info_mat.setConstant(-1.0);
  if (variant == 2) information.info_mat.setConstant(1e300);
}

void garble_observations(estimators::ObservationMessage& observations, int variant) {
  if (variant == 0) observations.origin_pose.x() = kNan;
  if (variant == 1) observations.origin_covariance << 1.0, 5.0, 0.0, 5.0, 1.0, 0.0, 0.0, 0.0, 1.0;
  if (variant == 2) observations.origin_step = -5;  // spans no longer follow the origin
}

}  // namespace

void make_hostile(estimators::Outbox& outbox, std::int64_t step) {
  const int variant = static_cast<int>(step % 3);
  if (outbox.state) garble_state(*outbox.state, variant);
  if (outbox.belief) garble_belief(*outbox.belief, variant);
  garble_consensus(outbox.consensus, variant);
  if (outbox.information) garble_information(*outbox.information, variant);
  if (outbox.observations) garble_observations(*outbox.observations, variant);
}

void make_hostile_if_listed(const std::vector<AgentId>& hostile_agents, AgentId agent,
                            estimators::Outbox& outbox, std::int64_t step) {
  if (std::find(hostile_agents.begin(), hostile_agents.end(), agent) != hostile_agents.end()) {
    make_hostile(outbox, step);
  }
}

}  // namespace swarmloc::runtime
