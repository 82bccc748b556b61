#pragma once
// Small worlds and estimates that the tests of what a run reports share: the run record's and run
// directory's own tests (tests/unit/rundir) and the same reports of simulated runs
// (tests/unit/sim/test_simulated_run_directory.cpp).
#include <cstddef>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/estimators/messages.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::testing {

inline constexpr double kNotANumber = std::numeric_limits<double>::quiet_NaN();
inline constexpr double kInfinity = std::numeric_limits<double>::infinity();

/// scenarios/ieif.yaml with 8 agents (3 anchors) in 15 m, 4 steps.
inline config::Scenario eight_agent_scenario() {
  return config::load_scenario(std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/ieif.yaml",
                               {"run.steps=4", "world.agents=8", "world.anchors=3", "world.area_m=15"});
}

/// Every agent at its truth plus 0.1 m east, with a unit covariance.
inline std::vector<std::optional<estimators::Estimate>> estimates_near_truth(const world::World& world) {
  std::vector<std::optional<estimators::Estimate>> estimates(world.truth.size());
  for (std::size_t i = 0; i < world.truth.size(); ++i) {
    estimators::Estimate estimate;
    estimate.mean_m = world.truth[i] + Vec2(0.1, 0.0);
    estimate.covariance = Mat2::Identity();
    estimate.valid = true;
    estimates[i] = estimate;
  }
  return estimates;
}

inline std::size_t first_non_anchor(const world::World& world) {
  std::size_t i = 0;
  while (world.is_anchor[i]) ++i;
  return i;
}

/// 12 agents (4 anchors) in 20 m, range noise 0.1 m, 30 steps: the plots' and TUM trajectories' world.
inline config::Scenario twelve_agent_scenario() {
  config::Scenario s;
  s.seed = 11;
  s.world.agents = 12;
  s.world.anchors = 4;
  s.world.area_m = 20.0;
  s.world.comm_radius_m = 12.0;
  s.noise.range_std_m = 0.1;
  s.run.steps = 30;
  return s;
}

}  // namespace swarmloc::testing
