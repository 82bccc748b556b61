// The agent manifest over DDS (include/swarmloc/dds/manifest_topic.hpp, docs/design.md "Agent manifests
// over DDS"). Beside convert.cpp, which converts the inter-agent families: this file is the manifest's
// one conversion, IDL <-> ManifestFields <-> the manifest file's JSON.
#include "swarmloc/dds/manifest_topic.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>

#include "endpoints.hpp"
#include "swarmloc.h"

namespace swarmloc::dds {
namespace {

using nlohmann::json;

/// runtime/manifest.cpp's format name: a sample is read as that file.
constexpr const char* kManifestFormat = "swarmloc-agent-manifest";
/// The manifest participant's lease: Cyclone re-announces a participant at 4/5 of it, also to every
/// unicast peer not yet found, so an agent that starts after the orchestrator finds it within ~1.6 s
/// (Cyclone's default, 10 s, re-announces every 8 s).
constexpr dds_duration_t kPublisherLease = DDS_SECS(2);

std::string partition(const std::string& run_id, AgentId id) {
  return (run_id.empty() ? std::string("*") : run_id) + ".manifest." + std::to_string(id);
}

std::string hex64(std::uint64_t value) {
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(value));
  return text;
}

/// The file's rules know finite numbers (and null for an unknown std or radius) only.
void require_finite(double value, const char* field, const std::string& source) {
  if (!std::isfinite(value))
    throw runtime::ManifestError(source + ": invalid agent manifest: " + field + " must be finite");
}

void require_finite_fields(const ManifestFields& f, const std::string& source) {
  const std::pair<double, const char*> numbers[] = {
      {f.initial_guess_m[0], "setup.initial_guess_m"},
      {f.initial_guess_m[1], "setup.initial_guess_m"},
      {f.initial_heading_rad, "setup.initial_heading_rad"},
      {f.initial_altitude_m, "setup.initial_altitude_m"},
      {f.clock_offset_s, "clock.offset_s"},
      {f.clock_drift_ppm, "clock.drift_ppm"},
      {f.loss_probability, "runtime.loss_probability"},
      {f.burst_mean_length, "runtime.burst_mean_length"},
      {f.absurd_position_bound_m, "runtime.absurd_position_bound_m"},
      {f.absurd_variance_m2, "runtime.absurd_variance_m2"},
      {f.world_period_s, "runtime.world_period_s"}};
  for (const auto& [value, field] : numbers) require_finite(value, field, source);
  // +inf (unknown) is the file's null; NaN and -inf have no file form.
  for (const auto& [value, field] : {std::pair{f.initial_guess_std_m, "setup.initial_guess_std_m"},
                                     std::pair{f.comm_radius_m, "setup.comm_radius_m"}}) {
    if (std::isnan(value) || value == -std::numeric_limits<double>::infinity())
      throw runtime::ManifestError(source + ": invalid agent manifest: " + field +
                                   " must be a number or +inf");
  }
}

/// The fields as the manifest file's JSON (runtime/manifest.cpp writes the same document).
json file_document(const ManifestFields& f, const std::string& source) {
  json runtime = {{"seed", hex64(f.seed)},
                  {"loss_probability", f.loss_probability},
                  {"burst_mean_length", f.burst_mean_length},
                  {"absurd_position_bound_m", f.absurd_position_bound_m},
                  {"absurd_variance_m2", f.absurd_variance_m2},
                  {"world_period_s", f.world_period_s}};
  if (f.has_partition) {
    json groups = json::object();
    for (const auto& [agent, group] : f.partition_groups) {
      const std::string key = std::to_string(agent);
      if (groups.contains(key)) {
        std::string message = source;
        message += ": invalid agent manifest: runtime.partition.groups lists agent ";
        message += key;
        message += " twice";
        throw runtime::ManifestError(message);
      }
      groups[key] = group;
    }
    runtime["partition"] = {
        {"from_step", f.partition_from_step}, {"to_step", f.partition_to_step}, {"groups", groups}};
  }
  auto finite_or_null = [](double value) { return std::isinf(value) ? json(nullptr) : json(value); };
  const json setup = {{"anchor", f.anchor},
                      {"initial_guess_m", {f.initial_guess_m[0], f.initial_guess_m[1]}},
                      {"initial_heading_rad", f.initial_heading_rad},
                      {"initial_guess_std_m", finite_or_null(f.initial_guess_std_m)},
                      {"comm_radius_m", finite_or_null(f.comm_radius_m)},
                      {"dimensions", f.dimensions},
                      {"initial_altitude_m", f.initial_altitude_m}};
  return {{"format", kManifestFormat},
          {"version", f.version},
          {"id", f.agent_id},
          {"agents", f.agent_count},
          {"run_id", f.run_id},
          {"results_hash", hex64(f.results_hash)},
          {"setup", setup},
          {"neighbours", f.neighbours},
          {"clock", {{"offset_s", f.clock_offset_s}, {"drift_ppm", f.clock_drift_ppm}}},
          {"runtime", runtime}};
}

// ---- IDL <-> fields ----

/// An IDL sample that points into its own buffers (alive as long as this object; not movable).
struct WireManifest {
  explicit WireManifest(const ManifestFields& f)
      : run_id(f.run_id), scenario_yaml(f.scenario_yaml), neighbours(f.neighbours) {
    for (const auto& [agent, group] : f.partition_groups) groups.push_back({agent, group});
    auto& s = sample;
    s.agent_id = f.agent_id;
    s.version = f.version;
    s.agent_count = f.agent_count;
    s.run_id = run_id.data();
    s.results_hash = f.results_hash;
    s.anchor = f.anchor;
    s.initial_guess_m[0] = f.initial_guess_m[0];
    s.initial_guess_m[1] = f.initial_guess_m[1];
    s.initial_heading_rad = f.initial_heading_rad;
    s.initial_guess_std_m = f.initial_guess_std_m;
    s.comm_radius_m = f.comm_radius_m;
    s.dimensions = f.dimensions;
    s.initial_altitude_m = f.initial_altitude_m;
    s.neighbours = {static_cast<uint32_t>(neighbours.size()), static_cast<uint32_t>(neighbours.size()),
                    neighbours.data(), false};
    s.clock_offset_s = f.clock_offset_s;
    s.clock_drift_ppm = f.clock_drift_ppm;
    s.seed = f.seed;
    s.loss_probability = f.loss_probability;
    s.burst_mean_length = f.burst_mean_length;
    s.absurd_position_bound_m = f.absurd_position_bound_m;
    s.absurd_variance_m2 = f.absurd_variance_m2;
    s.world_period_s = f.world_period_s;
    s.has_partition = f.has_partition;
    s.partition_from_step = f.partition_from_step;
    s.partition_to_step = f.partition_to_step;
    s.partition_groups = {static_cast<uint32_t>(groups.size()), static_cast<uint32_t>(groups.size()),
                          groups.data(), false};
    s.scenario_yaml = scenario_yaml.data();
  }
  WireManifest(const WireManifest&) = delete;
  WireManifest& operator=(const WireManifest&) = delete;

  std::string run_id;
  std::string scenario_yaml;
  std::vector<std::int32_t> neighbours;
  std::vector<swarmloc_msg_ManifestPartitionGroup> groups;
  swarmloc_msg_AgentManifest sample{};
};

ManifestFields decode(const swarmloc_msg_AgentManifest& s) {
  ManifestFields f;
  f.agent_id = s.agent_id;
  f.version = s.version;
  f.agent_count = s.agent_count;
  f.run_id = s.run_id != nullptr ? s.run_id : "";
  f.results_hash = s.results_hash;
  f.anchor = s.anchor;
  f.initial_guess_m[0] = s.initial_guess_m[0];
  f.initial_guess_m[1] = s.initial_guess_m[1];
  f.initial_heading_rad = s.initial_heading_rad;
  f.initial_guess_std_m = s.initial_guess_std_m;
  f.comm_radius_m = s.comm_radius_m;
  f.dimensions = s.dimensions;
  f.initial_altitude_m = s.initial_altitude_m;
  if (s.neighbours._buffer != nullptr)
    f.neighbours.assign(s.neighbours._buffer, s.neighbours._buffer + s.neighbours._length);
  f.clock_offset_s = s.clock_offset_s;
  f.clock_drift_ppm = s.clock_drift_ppm;
  f.seed = s.seed;
  f.loss_probability = s.loss_probability;
  f.burst_mean_length = s.burst_mean_length;
  f.absurd_position_bound_m = s.absurd_position_bound_m;
  f.absurd_variance_m2 = s.absurd_variance_m2;
  f.world_period_s = s.world_period_s;
  f.has_partition = s.has_partition;
  f.partition_from_step = s.partition_from_step;
  f.partition_to_step = s.partition_to_step;
  for (uint32_t k = 0; s.partition_groups._buffer != nullptr && k < s.partition_groups._length; ++k)
    f.partition_groups.emplace_back(s.partition_groups._buffer[k].agent, s.partition_groups._buffer[k].group);
  f.scenario_yaml = s.scenario_yaml != nullptr ? s.scenario_yaml : "";
  return f;
}

QosPtr manifest_qos() {
  config::QosSettings settings;
  settings.reliability = config::Reliability::kReliable;
  settings.history_depth = 1;  // per instance, i.e. per agent
  settings.durability = config::Durability::kTransientLocal;
  settings.deadline_s = 0.0;
  settings.liveliness_lease_s = 0.0;
  return endpoint_qos(settings);
}

}  // namespace

ManifestFields manifest_fields(const runtime::AgentManifest& m, const std::string& scenario_yaml) {
  ManifestFields f;
  f.agent_id = m.id;
  f.version = runtime::kManifestVersion;
  f.agent_count = m.agent_count;
  f.run_id = m.run_id;
  f.results_hash = m.results_hash;
  f.anchor = m.setup.anchor;
  f.initial_guess_m[0] = m.setup.initial_guess_m.x();
  f.initial_guess_m[1] = m.setup.initial_guess_m.y();
  f.initial_heading_rad = m.setup.initial_heading_rad;
  f.initial_guess_std_m = m.setup.initial_guess_std_m;
  f.comm_radius_m = m.setup.comm_radius_m;
  f.dimensions = m.setup.dimensions;
  f.initial_altitude_m = m.setup.initial_altitude_m;
  f.neighbours.assign(m.neighbours.begin(), m.neighbours.end());
  f.clock_offset_s = m.clock.offset_s;
  f.clock_drift_ppm = m.clock.drift_ppm;
  const runtime::AgentRuntimeParams& p = m.runtime;
  f.seed = p.seed;
  f.loss_probability = p.loss.loss_probability;
  f.burst_mean_length = p.loss.burst_mean_length;
  f.absurd_position_bound_m = p.absurd_position_bound_m;
  f.absurd_variance_m2 = p.absurd_variance_m2;
  f.world_period_s = p.world_period_s;
  f.has_partition = !p.partition_group.empty();
  f.partition_from_step = p.partition_from;
  f.partition_to_step = p.partition_to;
  auto add_group = [&](AgentId agent) {
    const auto at = static_cast<std::size_t>(agent);
    if (agent >= 0 && at < p.partition_group.size())
      f.partition_groups.emplace_back(agent, p.partition_group[at]);
  };
  if (f.has_partition) {
    add_group(m.id);
    for (const AgentId neighbour : m.neighbours) add_group(neighbour);
  }
  f.scenario_yaml = scenario_yaml;
  return f;
}

ManifestOffer read_manifest_fields(const ManifestFields& fields, const std::string& source) {
  require_finite_fields(fields, source);
  if (fields.scenario_yaml.empty())
    throw runtime::ManifestError(source + ": invalid agent manifest: scenario_yaml is empty");
  std::string text;
  try {
    text = file_document(fields, source).dump();
  } catch (const nlohmann::json::exception& error) {  // e.g. a run id that is not UTF-8
    throw runtime::ManifestError(source + ": invalid agent manifest: " + error.what());
  }
  return ManifestOffer{runtime::parse_manifest(text, source), fields.scenario_yaml};
}

// ===================================================================================================
// Orchestrator side

struct ManifestPublisher::Impl {
  Impl(const config::Scenario& scenario, int agent_count)
      : run_id(scenario.dds.run_id),
        agents(agent_count),
        block_size(measurement_block_size(scenario, agent_count)),
        domain(static_cast<dds_domainid_t>(scenario.dds.domain_id),
               cyclone_config(scenario, Topology{kOrchestratorId, agent_count, {}})),
        participant(create()) {
    const dds_entity_t topic =
        create_topic(participant.get(), swarmloc_msg_AgentManifest_desc, kTopicManifest);
    const auto qos = manifest_qos();
    // One writer per block of agents (as the measurements: docs/scale.md), its publisher in each block
    // member's own partition, so agent i's reader ("<run>.manifest.<i>") matches one writer only.
    for (int first = 0; first < agent_count; first += block_size) {
      std::vector<std::string> names;
      for (AgentId id = first; id < std::min(agent_count, first + block_size); ++id)
        names.push_back(partition(run_id, id));
      const dds_entity_t publisher = create_publisher(participant.get(), names);
      writers.push_back(check(dds_create_writer(publisher, topic, qos.get(), nullptr), "dds_create_writer",
                              kTopicManifest));
    }
  }

  dds_entity_t create() const {
    const QosPtr qos(dds_create_qos());
    dds_qset_liveliness(qos.get(), DDS_LIVELINESS_AUTOMATIC, kPublisherLease);
    return check(dds_create_participant(domain.domain_id(), qos.get(), nullptr), "dds_create_participant",
                 "(agent manifests)");
  }

  std::string run_id;
  int agents = 0;
  int block_size = 1;
  DomainLease domain;
  Entity participant;
  std::vector<dds_entity_t> writers;
};

ManifestPublisher::ManifestPublisher(const config::Scenario& scenario, int agent_count)
    : impl_(std::make_unique<Impl>(scenario, agent_count)) {}

ManifestPublisher::~ManifestPublisher() = default;

void ManifestPublisher::publish(const std::vector<runtime::AgentManifest>& manifests,
                                const std::string& scenario_yaml) {
  for (const auto& manifest : manifests) publish_fields(manifest_fields(manifest, scenario_yaml));
}

void ManifestPublisher::publish_fields(const ManifestFields& fields) {
  if (fields.agent_id < 0 || fields.agent_id >= impl_->agents)
    throw DdsError("ManifestPublisher: agent " + std::to_string(fields.agent_id) + " is not in this run");
  const WireManifest wire(fields);
  check(
      dds_write(impl_->writers[static_cast<std::size_t>(fields.agent_id / impl_->block_size)], &wire.sample),
      "dds_write", kTopicManifest);
}

int ManifestPublisher::matched_readers() const {
  int matched = 0;
  for (const dds_entity_t writer : impl_->writers) matched += matched_reader_count(writer);
  return matched;
}

// ===================================================================================================
// Agent side

namespace {

/// Every sample for agent `id` taken now: accepted ones appended, rejected ones counted.
void take_manifests(dds_entity_t reader, AgentId id, int domain_id, std::vector<ManifestOffer>& accepted,
                    ManifestWaitStats& stats) {
  take_all<swarmloc_msg_AgentManifest>(reader, [&](const swarmloc_msg_AgentManifest& wire) {
    if (wire.agent_id != id) return;  // a block-mate's: never read
    const ManifestFields fields = decode(wire);
    const std::string source = "manifest sample for agent " + std::to_string(id) + " (run \"" +
                               fields.run_id + "\", DDS domain " + std::to_string(domain_id) + ")";
    try {
      accepted.push_back(read_manifest_fields(fields, source));
    } catch (const runtime::ManifestError& error) {
      ++stats.rejected;
      stats.last_rejection = error.what();
    }
  });
}

}  // namespace

ManifestOffer receive_manifest(const config::Scenario& scenario, AgentId id, double timeout_s,
                               ManifestWaitStats* stats_out) {
  if (id < 0) throw runtime::ManifestError("agent id " + std::to_string(id) + " is not an agent");
  ManifestWaitStats stats;
  std::vector<ManifestOffer> accepted;
  {
    // At agent id's own discovery port, its only Peer that port itself: the orchestrator lists every
    // agent's port and finds us (we do not know the agent count, hence not its port, yet).
    const DomainLease domain(static_cast<dds_domainid_t>(scenario.dds.domain_id),
                             cyclone_config(scenario, Topology{id, id, {}}));
    const Entity participant(create_participant(domain));
    const dds_entity_t pp = participant.get();
    const dds_entity_t topic = create_topic(pp, swarmloc_msg_AgentManifest_desc, kTopicManifest);
    const dds_entity_t subscriber = create_subscriber(pp, {partition(scenario.dds.run_id, id)});
    const auto qos = manifest_qos();
    const dds_entity_t reader =
        check(dds_create_reader(subscriber, topic, qos.get(), nullptr), "dds_create_reader", kTopicManifest);
    const dds_entity_t waitset = check(dds_create_waitset(pp), "dds_create_waitset");
    attach_reader(waitset, reader);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (accepted.empty()) {
      const double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
      if (left <= 0.0) break;
      wait(waitset, std::min(left, 0.5));
      take_manifests(reader, id, scenario.dds.domain_id, accepted, stats);
    }
  }  // the participant and its port are gone before the agent's own transport takes them
  if (stats_out != nullptr) *stats_out = stats;
  std::set<std::string> runs;
  for (const auto& offer : accepted) runs.insert(offer.manifest.run_id);
  if (runs.size() > 1) {
    throw runtime::ManifestError("runs \"" + *runs.begin() + "\" and \"" + *std::next(runs.begin()) +
                                 "\" both offer agent " + std::to_string(id) + "'s manifest on DDS domain " +
                                 std::to_string(scenario.dds.domain_id) + ": name one with --run-id");
  }
  if (!accepted.empty()) return std::move(accepted.back());
  if (stats.rejected > 0) {
    throw runtime::ManifestError(stats.last_rejection + " (" + std::to_string(stats.rejected) +
                                 " manifest sample(s) rejected, none accepted)");
  }
  throw ManifestTimeout(
      "no manifest for agent " + std::to_string(id) + " on DDS domain " +
      std::to_string(scenario.dds.domain_id) + " (run " +
      (scenario.dds.run_id.empty() ? std::string("any") : "\"" + scenario.dds.run_id + "\"") + ") within " +
      std::to_string(static_cast<int>(std::lround(timeout_s))) +
      " s: is `swarmloc run --no-launch` running with this dds.domain_id, and can this "
      "host reach it (dds.interface, dds.neighbour_discovery)?");
}

}  // namespace swarmloc::dds
