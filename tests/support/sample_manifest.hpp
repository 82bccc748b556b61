#pragma once
// One agent manifest with every field set to a value that a lossy write or read would change (odd
// decimals, large integers, a partition): the fixture of the manifest file and DDS topic tests.
#include <string>

#include "swarmloc/runtime/manifest.hpp"

namespace swarmloc::testing {

/// Agent `id` of 7; agent 3 is an anchor with neighbours 0, 2, 6, any other agent has neighbour 3.
inline runtime::AgentManifest sample_manifest(AgentId id = 3, const std::string& run_id = "r-abc_123") {
  runtime::AgentManifest m;
  m.id = id;
  m.agent_count = 7;
  m.setup = estimators::AgentSetup{id, id == 3, Vec2(0.1 + 0.2, 1.0 / 3.0), -2.5e-7, 0.75};
  m.neighbours = {0, 2, 6};
  if (id != 3) m.neighbours = {3};
  m.clock = core::ClockModel{0.0123456789012345, -37.25};
  m.runtime.seed = 0xfedcba9876543210ULL;
  m.runtime.loss.loss_probability = 0.2;
  m.runtime.loss.burst_mean_length = 3.5;
  m.runtime.absurd_position_bound_m = 123456.0;
  m.runtime.world_period_s = 0.1;
  m.runtime.partition_group = {0, 1, 1, 0, 1, 0, 1};
  m.runtime.partition_from = 5;
  m.runtime.partition_to = 9;
  m.results_hash = 0x0123456789abcdefULL;
  m.run_id = run_id;
  return m;
}

}  // namespace swarmloc::testing
