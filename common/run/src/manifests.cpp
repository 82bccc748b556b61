#include "swarmloc/run/manifests.hpp"

#include <algorithm>

namespace swarmloc::run {

std::vector<runtime::AgentManifest> make_agent_manifests(const config::Scenario& s, const world::World& world,
                                                         std::uint64_t trial) {
  const runtime::AgentManifest shared = shared_manifest(s, world, trial);
  std::vector<runtime::AgentManifest> manifests;
  manifests.reserve(static_cast<std::size_t>(world.size()));
  for (AgentId i = 0; i < world.size(); ++i) manifests.push_back(agent_manifest(shared, world, i));
  return manifests;
}

runtime::AgentManifest shared_manifest(const config::Scenario& s, const world::World& world,
                                       std::uint64_t trial) {
  runtime::AgentManifest m;
  m.agent_count = world.size();
  m.runtime.seed = world::trial_seed(s.seed, trial);
  m.runtime.loss.loss_probability = s.network.loss;
  m.runtime.loss.burst_mean_length = s.network.burst.mean_length;
  m.runtime.absurd_position_bound_m = world::absurd_position_bound_m(s);
  m.runtime.world_period_s = 1.0 / s.run.rate_hz;
  if (const auto window = config::parse_partition(s.faults.partition)) {
    m.runtime.partition_from = window->from_step;
    m.runtime.partition_to = window->to_step;
    m.runtime.partition_group = partition_groups(world);
  }
  m.results_hash = config::results_hash(s);
  m.run_id = s.dds.run_id;
  return m;
}

runtime::AgentManifest agent_manifest(const runtime::AgentManifest& shared, const world::World& world,
                                      AgentId id) {
  const auto k = static_cast<std::size_t>(id);
  runtime::AgentManifest m = shared;
  m.id = id;
  m.setup = world.setup_of(id);
  m.neighbours = world.neighbours.at(k);
  m.clock = world.clocks.at(k);
  return m;
}

std::vector<std::uint8_t> partition_groups(const world::World& world) {
  std::vector<double> xs;
  xs.reserve(world.truth.size());
  for (const auto& p : world.truth) xs.push_back(p.x());
  std::vector<double> sorted = xs;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2),
                   sorted.end());
  const double median = sorted.empty() ? 0.0 : sorted[sorted.size() / 2];
  std::vector<std::uint8_t> group;
  group.reserve(xs.size());
  for (const double x : xs) group.push_back(x < median ? 0 : 1);
  return group;
}

}  // namespace swarmloc::run
