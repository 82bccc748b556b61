#pragma once
// A hand-made world for the optimum's tests: every pair of agents in range, the first `anchors` of them
// anchors, each agent starting from its truth.
#include <utility>
#include <vector>

#include "swarmloc/world/world.hpp"

namespace swarmloc::testing {

/// A planar world of `truth`; give it `altitude` (one z per agent) for a 3-D world.
inline world::World fully_linked_world(std::vector<Vec2> truth, int anchors,
                                       std::vector<double> altitude = {}) {
  world::World world;
  world.truth = std::move(truth);
  const std::size_t n = world.truth.size();
  world.is_anchor.assign(n, false);
  for (int a = 0; a < anchors; ++a) world.is_anchor[static_cast<std::size_t>(a)] = true;
  world.neighbours.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = 0; j < n; ++j) {
      if (i != j) world.neighbours[i].push_back(static_cast<AgentId>(j));
    }
  }
  world.initial_guess = world.truth;
  if (!altitude.empty()) {
    world.dimensions = 3;
    world.altitude = std::move(altitude);
    world.initial_altitude = world.altitude;
  }
  return world;
}

}  // namespace swarmloc::testing
