#pragma once
// A deliberately broken publisher for robustness runs (issue 5: "an injected hostile agent"): the
// DDS agent started with --hostile and the simulator's SimOptions::hostile_agents garble the same way.
#include <cstdint>
#include <vector>

#include "swarmloc/estimators/messages.hpp"

namespace swarmloc::runtime {

/// Replaces every family of `outbox` by broken samples of the same kind: NaN, non-PSD and absurd
/// magnitudes in turn (by `step` mod 3).
void make_hostile(estimators::Outbox& outbox, std::int64_t step);

/// make_hostile if `agent` is one of `hostile_agents` (the simulators' SimOptions::hostile_agents).
void make_hostile_if_listed(const std::vector<AgentId>& hostile_agents, AgentId agent,
                            estimators::Outbox& outbox, std::int64_t step);

}  // namespace swarmloc::runtime
