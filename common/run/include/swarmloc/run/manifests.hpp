#pragma once
// Run preparation: what the orchestrator hands each agent of a world before the run starts. One
// function per job; both runtimes (the DDS agent processes and the in-process simulator) start their
// agents from these manifests, so they construct identical agents (docs/architecture.md, "What an agent
// knows").
#include <cstdint>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/runtime/manifest.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::run {

/// What each agent of `world` may know (runtime/manifest.hpp), in id order: its id and the network's
/// size, its setup, its neighbours, its clock, its runtime parameters (trial seed, loss, plausibility
/// bounds, world period, the partition window and groups) and the run's identity.
std::vector<runtime::AgentManifest> make_agent_manifests(const config::Scenario& scenario,
                                                         const world::World& world, std::uint64_t trial = 0);

/// The part of every manifest that all agents share: the network's size, the runtime parameters (with
/// the partition groups, computed once) and the run's identity. For runtimes that make one agent at a
/// time (the simulator: a dense world's neighbour lists are too large to hold twice).
runtime::AgentManifest shared_manifest(const config::Scenario& scenario, const world::World& world,
                                       std::uint64_t trial = 0);

/// Agent `id`'s manifest: `shared` with its id, setup, neighbours and clock.
runtime::AgentManifest agent_manifest(const runtime::AgentManifest& shared, const world::World& world,
                                      AgentId id);

/// faults.partition's halves: 0 west of the median true x at step 0, 1 east (and on it).
std::vector<std::uint8_t> partition_groups(const world::World& world);

}  // namespace swarmloc::run
