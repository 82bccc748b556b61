// The orchestrator's agent manifests: what an agent process starts from instead of the world. Through
// the file, every agent gets the runtime parameters the scenario and the world fix and the estimator the
// in-memory manifest builds (the simulator starts its agents from the same manifests; the
// lockstep-equals-simulator tests check the whole run over DDS).
#include <gtest/gtest.h>

#include "swarmloc/run/manifests.hpp"
#include "swarmloc/runtime/agent_factory.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::run {
namespace {

const std::string kManifestScenarioFile = SWARMLOC_SOURCE_DIR "/scenarios/ieif.yaml";

config::Scenario manifest_scenario(const std::vector<std::string>& overrides) {
  auto s = config::load_scenario(kManifestScenarioFile, overrides);
  s.dds.run_id = "manifest-test";
  return s;
}

void expect_same_params(const runtime::AgentRuntimeParams& file,
                        const runtime::AgentRuntimeParams& world_params, const runtime::AgentManifest& m) {
  EXPECT_EQ(file.seed, world_params.seed);
  EXPECT_EQ(file.loss.loss_probability, world_params.loss.loss_probability);
  EXPECT_EQ(file.loss.burst_mean_length, world_params.loss.burst_mean_length);
  EXPECT_EQ(file.absurd_position_bound_m, world_params.absurd_position_bound_m);
  EXPECT_EQ(file.absurd_variance_m2, world_params.absurd_variance_m2);
  EXPECT_EQ(file.world_period_s, world_params.world_period_s);
  EXPECT_EQ(file.first_seq, world_params.first_seq);
  EXPECT_EQ(file.partition_from, world_params.partition_from);
  EXPECT_EQ(file.partition_to, world_params.partition_to);
  ASSERT_EQ(file.partition_group.empty(), world_params.partition_group.empty());
  if (file.partition_group.empty()) return;
  auto side = [](const runtime::AgentRuntimeParams& p, AgentId a) {
    return p.partition_group.at(static_cast<std::size_t>(a));
  };
  EXPECT_EQ(side(file, m.id), side(world_params, m.id));
  for (const AgentId neighbour : m.neighbours)
    EXPECT_EQ(side(file, neighbour), side(world_params, neighbour));
}

/// What the scenario and the world fix for every agent's runtime, written out from docs/architecture.md
/// ("What an agent knows") rather than through make_agent_manifests.
runtime::AgentRuntimeParams expected_params(const config::Scenario& s, const world::World& world,
                                            int incarnation) {
  runtime::AgentRuntimeParams p;
  p.seed = world::trial_seed(s.seed, 0);
  p.loss.loss_probability = s.network.loss;
  p.loss.burst_mean_length = s.network.burst.mean_length;
  p.absurd_position_bound_m = world::absurd_position_bound_m(s);
  p.world_period_s = 1.0 / s.run.rate_hz;
  p.first_seq = static_cast<std::uint32_t>(incarnation) << 24;
  if (const auto window = config::parse_partition(s.faults.partition)) {
    p.partition_from = window->from_step;
    p.partition_to = window->to_step;
    p.partition_group = partition_groups(world);
  }
  return p;
}

void expect_file_matches_world(const std::vector<std::string>& overrides) {
  const auto scenario = manifest_scenario(overrides);
  const world::World world = world::build_world(scenario);
  const auto manifests = make_agent_manifests(scenario, world);
  ASSERT_EQ(static_cast<int>(manifests.size()), world.size());
  for (const auto& written : manifests) {
    const AgentId i = written.id;
    SCOPED_TRACE("agent " + std::to_string(i));
    const runtime::AgentManifest m = runtime::parse_manifest(runtime::to_json_text(written), "memory");
    EXPECT_EQ(m.neighbours, world.neighbours[static_cast<std::size_t>(i)]);
    EXPECT_EQ(m.clock.offset_s, world.clocks[static_cast<std::size_t>(i)].offset_s);
    EXPECT_EQ(m.clock.drift_ppm, world.clocks[static_cast<std::size_t>(i)].drift_ppm);
    EXPECT_EQ(m.setup.initial_guess_m, world.setup_of(i).initial_guess_m);
    EXPECT_EQ(m.setup.anchor, world.setup_of(i).anchor);
    EXPECT_EQ(m.results_hash, config::results_hash(scenario));
    EXPECT_EQ(m.run_id, "manifest-test");
    for (const int incarnation : {0, 2})
      expect_same_params(runtime::make_runtime_params(m, incarnation),
                         expected_params(scenario, world, incarnation), m);
    const auto from_file = runtime::make_agent_estimator(scenario, m)->estimate();
    const auto from_world = runtime::make_agent_estimator(scenario, written)->estimate();
    EXPECT_EQ(from_file.mean_m, from_world.mean_m);
    EXPECT_EQ(from_file.covariance, from_world.covariance);
  }
}

TEST(AgentManifests, ThroughTheFileEveryAgentGetsWhatTheSimulatorGivesIt) {
  expect_file_matches_world({});
  expect_file_matches_world({"faults.partition=10-20", "network.loss=0.1", "algorithm.name=dgbb"});
  expect_file_matches_world({"algorithm.name=ekf"});  // sensor-only agents
}

TEST(AgentManifests, HoldNothingAboutAgentsBeyondTheNeighbours) {
  const auto scenario = manifest_scenario({"faults.partition=10-20"});
  const world::World world = world::build_world(scenario);
  const auto m = make_agent_manifests(scenario, world).at(3);
  const auto text = runtime::to_json_text(m);
  for (AgentId other = 0; other < world.size(); ++other) {
    if (other == m.id || std::binary_search(m.neighbours.begin(), m.neighbours.end(), other)) continue;
    EXPECT_EQ(text.find("\"" + std::to_string(other) + "\":"), std::string::npos) << "agent " << other;
  }
}

}  // namespace
}  // namespace swarmloc::run
