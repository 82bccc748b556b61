#include "swarmloc/runtime/hostile.hpp"

#include <algorithm>
#include <limits>

namespace swarmloc::sim {

void make_hostile(estimators::Outbox& outbox, std::int64_t step) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const int variant = static_cast<int>(step % 3);
  if (outbox.state) {
    auto& state = *outbox.state;
    state.mean_m = Vec2(20.0, 20.0);
    state.covariance = Mat2::Identity() * 0.01;
    if (variant == 0) state.mean_m.x() = nan;
    if (variant == 1) state.covariance << 1.0, 5.0, 5.0, 1.0;  // eigenvalues 6 and −4
    if (variant == 2) state.mean_m = Vec2(1e12, -1e12);
  }
  if (outbox.belief) {
    auto& belief = *outbox.belief;
    belief.infinite_information = false;
    belief.information = Mat2::Identity();
    if (!belief.contributions.empty() && variant != 1) {
      // Exact GaBP: a belief that is well formed itself, with broken contributions.
      for (auto& contribution : belief.contributions) {
        if (variant == 0) contribution.info_vec.x() = nan;
        if (variant == 2) contribution.information = Mat2::Identity() * 1e300;
      }
    } else {
      if (variant == 0) belief.mean_m.x() = nan;
      if (variant == 1) belief.information << 1.0, 5.0, 5.0, 1.0;
      if (variant == 2) belief.mean_m = Vec2(1e12, -1e12);
    }
  }
  for (auto& consensus : outbox.consensus) {
    for (double& value : consensus.values) value = variant == 0 ? nan : (variant == 1 ? -1e300 : 1e300);
  }
  if (outbox.information) {
    auto& information = *outbox.information;
    if (variant == 0) information.info_vec.setConstant(nan);
    if (variant == 1 && information.info_mat.size() > 0) information.info_mat.setConstant(-1.0);
    if (variant == 2) information.info_mat.setConstant(1e300);
  }
}

void make_hostile_if_listed(const std::vector<AgentId>& hostile_agents, AgentId agent,
                            estimators::Outbox& outbox, std::int64_t step) {
  if (std::find(hostile_agents.begin(), hostile_agents.end(), agent) != hostile_agents.end()) {
    make_hostile(outbox, step);
  }
}

}  // namespace swarmloc::sim
