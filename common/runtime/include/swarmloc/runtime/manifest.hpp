#pragma once
// Everything one agent may know, computed once by the orchestrator from the world it owns: the agent's
// id and the network's size, its setup (anchor flag and fix, initial guess), its neighbours, its clock,
// its runtime parameters, and which scenario and run it belongs to. An agent process starts from this and
// its scenario file; it never sees the world (truth, other agents' positions, the graph beyond its own
// links): the knowledge boundary is this type.
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "swarmloc/core/clock.hpp"
#include "swarmloc/core/types.hpp"
#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/runtime/agent_runtime.hpp"

namespace swarmloc::runtime {

struct AgentManifest {
  AgentId id = 0;
  int agent_count = 0;
  estimators::AgentSetup setup;     ///< setup.id == id
  std::vector<AgentId> neighbours;  ///< sorted, without id
  core::ClockModel clock;
  /// Seed, loss, plausibility bounds, partition window. partition_group is indexed by agent id; only the
  /// entries of this agent and its neighbours are meaningful (the runtime compares no others), and only
  /// those are written to the file.
  AgentRuntimeParams runtime;
  /// config::results_hash of the run's scenario: what decides results (transport settings may differ
  /// between hosts); an agent refuses a scenario file that hashes differently.
  std::uint64_t results_hash = 0;
  std::string run_id;  ///< dds.run_id of the run
};

/// A manifest file that cannot be read or is not a valid manifest (the agent exits with code 2).
class ManifestError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

inline constexpr int kManifestVersion = 1;
/// <run>/manifests/agent_<id>.json (three digits at least, like the logs).
std::filesystem::path manifest_path(const std::filesystem::path& run_dir, AgentId id);

/// The manifest as JSON text (doubles round-trip exactly).
std::string to_json_text(const AgentManifest& manifest);
/// Parses and validates; throws ManifestError naming `source` and the offending field.
AgentManifest parse_manifest(const std::string& text, const std::string& source);
/// Writes `manifest` to `path` (parent directories created); throws OutputError on a failed write.
void write_manifest(const std::filesystem::path& path, const AgentManifest& manifest);
/// Reads and validates `path`; throws ManifestError.
AgentManifest load_manifest(const std::filesystem::path& path);

}  // namespace swarmloc::runtime
