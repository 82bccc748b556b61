#pragma once
// Where an algorithm runs: in every agent, or in one fusion centre that the agents feed with their
// measurement batches (docs/algorithms.md §2.7). The transport, the agent process and the simulator ask
// this instead of testing algorithm names themselves.
#include <string_view>

namespace swarmloc::sim {

/// True for the algorithms that run in a fusion centre instead of in every agent (ekf, lbekf, lbekf_vr,
/// lbekf_i).
bool is_centralized(std::string_view algorithm);

}  // namespace swarmloc::sim
