#pragma once
// The agent manifest over DDS, for agents the orchestrator does not launch (`swarmloc run --no-launch`,
// containers, other hosts): the orchestrator offers each agent's manifest (runtime/manifest.hpp) and the
// run's scenario.yaml as one reliable, transient-local sample on topic swarmloc_manifest, keyed by agent
// id, in partition "<run_id>.manifest.<id>" (docs/design.md, "Agent manifests over DDS"). A received
// sample passes exactly the checks of a manifest file: it is read through parse_manifest.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/dds/transport.hpp"
#include "swarmloc/runtime/manifest.hpp"

namespace swarmloc::dds {

inline constexpr const char* kTopicManifest = "swarmloc_manifest";

/// What an agent started elsewhere receives: its manifest and the run's scenario (YAML, as the run
/// directory's scenario.yaml).
struct ManifestOffer {
  runtime::AgentManifest manifest;
  std::string scenario_yaml;
};

/// The sample's fields as they travel (idl/swarmloc.idl, AgentManifest), before any check: what a
/// hostile or garbled writer can put on the wire.
struct ManifestFields {
  std::int32_t agent_id = 0;
  std::int32_t version = 0;
  std::int32_t agent_count = 0;
  std::string run_id;
  std::uint64_t results_hash = 0;
  bool anchor = false;
  double initial_guess_m[2] = {0.0, 0.0};
  double initial_heading_rad = 0.0;
  double initial_guess_std_m = 0.0;
  double comm_radius_m = 0.0;
  std::int32_t dimensions = 2;
  double initial_altitude_m = 0.0;
  std::vector<std::int32_t> neighbours;
  double clock_offset_s = 0.0;
  double clock_drift_ppm = 0.0;
  std::uint64_t seed = 0;
  double loss_probability = 0.0;
  double burst_mean_length = 0.0;
  double absurd_position_bound_m = 0.0;
  double absurd_variance_m2 = 0.0;
  double world_period_s = 0.0;
  bool has_partition = false;
  std::int64_t partition_from_step = 0;
  std::int64_t partition_to_step = 0;
  std::vector<std::pair<std::int32_t, std::uint8_t>> partition_groups;  ///< (agent, group)
  std::string scenario_yaml;
};

/// The fields of `manifest` (only its own and its neighbours' partition groups, as in the file).
ManifestFields manifest_fields(const runtime::AgentManifest& manifest, const std::string& scenario_yaml);
/// Checks and converts: the fields become the manifest file's JSON and go through parse_manifest,
/// so a sample is held to exactly the file's rules. Throws runtime::ManifestError naming `source` and the
/// field; never anything else, whatever the fields hold.
ManifestOffer read_manifest_fields(const ManifestFields& fields, const std::string& source);

/// Orchestrator side: one participant of its own (sharing the orchestrator's domain) that keeps every
/// offered manifest for late joiners as long as it lives.
class ManifestPublisher {
 public:
  ManifestPublisher(const config::Scenario& scenario, int agent_count);
  ~ManifestPublisher();
  ManifestPublisher(const ManifestPublisher&) = delete;
  ManifestPublisher& operator=(const ManifestPublisher&) = delete;

  /// Offers manifests[i] to agent manifests[i].id, each with `scenario_yaml`.
  void publish(const std::vector<runtime::AgentManifest>& manifests, const std::string& scenario_yaml);
  /// Offers `fields` as they are, unchecked, to agent fields.agent_id (tests of a hostile writer).
  void publish_fields(const ManifestFields& fields);
  /// Agents' manifest readers matched so far.
  [[nodiscard]] int matched_readers() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// No manifest arrived in time (the process exits 1: a runtime failure, not bad input).
class ManifestTimeout : public DdsError {
 public:
  using DdsError::DdsError;
};

struct ManifestWaitStats {
  int rejected = 0;  ///< samples for this agent that failed the checks (each logged by the caller's error)
  std::string last_rejection;
};

/// Agent side: waits up to timeout_s for agent `id`'s manifest, on a participant of its own made from
/// `scenario`'s dds settings (domain, interface, discovery, security) at agent `id`'s discovery port,
/// deleted before returning. With scenario.dds.run_id empty it takes the manifest of any run on the
/// domain (and throws runtime::ManifestError if two runs offer one at once). A rejected sample is counted
/// and the wait goes on (the real orchestrator may still answer); at the deadline, throws
/// runtime::ManifestError with the last rejection if there was one, else ManifestTimeout.
ManifestOffer receive_manifest(const config::Scenario& scenario, AgentId id, double timeout_s,
                               ManifestWaitStats* stats = nullptr);

}  // namespace swarmloc::dds
