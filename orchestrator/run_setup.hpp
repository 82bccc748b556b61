#pragma once
// `swarmloc run` before the orchestrator starts: the scenario loaded, bad input found and the run
// directory prepared, before any work (run_orchestrator(const RunOptions&) is defined beside these).
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "orchestrator.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/dds/manifest_topic.hpp"
#include "swarmloc/runtime/liveness.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::orchestrator {

/// 12 hex digits from the OS's entropy: a run id no other run on the domain shares.
std::string fresh_run_id();

/// Checks the scenario and options (--hostile ids, DDS ports, security files), prepares the run
/// directory (set in `run_dir`; `run_dir_existed`: whether it existed before) and builds the run's world.
/// Throws config::ScenarioError on bad input, world::Cancelled on Ctrl-C; `run_dir` and `run_dir_existed`
/// are set as far as it got, for the caller to discard an empty directory.
world::World prepare_run(config::Scenario& scenario, const RunOptions& options,
                         const world::WorkControl& control, std::filesystem::path& run_dir,
                         bool& run_dir_existed);

/// Agents we do not launch (`launch_agents` false) wait for their manifests on DDS: each offered as a
/// transient-local sample, with the scenario as run, for as long as the returned publisher lives. Null
/// when we launch the agents (they read the files).
std::unique_ptr<dds::ManifestPublisher> offer_manifests(const config::Scenario& scenario,
                                                        const std::vector<runtime::AgentManifest>& manifests,
                                                        bool launch_agents);

/// How old an estimate may be and still count as current, and when silence is a stall (free run: a few
/// world periods; lockstep: the barrier decides, docs/robustness.md "Liveness").
runtime::LivenessLimits liveness_limits(const config::Scenario& scenario, bool lockstep);

/// Free run: the world loop, and the threads it creates from now on (Cyclone's), at real-time priority
/// when the system allows it (docs/scale.md, "The world loop"); "realtime", or "normal" with a log line
/// saying why not.
std::string raise_world_priority();

}  // namespace swarmloc::orchestrator
