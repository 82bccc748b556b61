#pragma once
// Where an algorithm runs: in every agent, or in one fusion centre that the agents feed with their
// measurement batches (docs/algorithms.md §2.7). The answer is the algorithm's registry entry
// (config/algorithms.hpp); the transport, the agent process and the simulator ask this instead of testing
// algorithm names themselves.
#include <string_view>

#include "swarmloc/config/algorithms.hpp"

namespace swarmloc::sim {

/// True for the algorithms whose registry entry places them in the fusion centre (ekf, lbekf, lbekf_vr,
/// lbekf_i); false for the others and for unknown names.
inline bool is_centralized(std::string_view algorithm) { return config::runs_in_fusion_centre(algorithm); }

}  // namespace swarmloc::sim
