#pragma once
// Helpers shared by the transports (transport.cpp, fusion_transport.cpp): topic and partition names,
// entity creation with checked return codes, loaned takes and waitsets. Private to common/dds/src.
#include <dds/dds.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "entities.hpp"
#include "qos.hpp"

namespace swarmloc::dds {

inline constexpr const char* kTopicMeasurements = "swarmloc_measurements";
inline constexpr const char* kTopicState = "swarmloc_state";
inline constexpr const char* kTopicInformation = "swarmloc_information";
inline constexpr const char* kTopicConsensus = "swarmloc_consensus";
inline constexpr const char* kTopicBelief = "swarmloc_belief";
inline constexpr const char* kTopicObservations = "swarmloc_observations";
inline constexpr const char* kTopicEstimate = "swarmloc_estimate";
inline constexpr const char* kTopicControl = "swarmloc_control";

/// Partition names, each prefixed by the run id ("<run_id>.ctl"), so that two runs on one domain never
/// see each other's samples (docs/robustness.md, "Run isolation"). An empty run id (unit tests of the
/// transport alone) leaves the bare names.
class Partitions {
 public:
  explicit Partitions(const std::string& run_id) : prefix_(run_id.empty() ? std::string() : run_id + ".") {}
  [[nodiscard]] std::string estimates() const { return prefix_ + "est"; }
  [[nodiscard]] std::string control() const { return prefix_ + "ctl"; }
  [[nodiscard]] std::string nothing() const { return prefix_ + "none"; }
  [[nodiscard]] std::string agent(AgentId agent) const { return prefix_ + "a" + std::to_string(agent); }
  [[nodiscard]] std::string measurement(int block) const { return prefix_ + "m" + std::to_string(block); }
  /// "a<j>" of this run: j; anything else (another run's, another family's): nullopt.
  [[nodiscard]] std::optional<AgentId> agent_of(const std::string& name) const {
    if (name.size() <= prefix_.size() + 1 || name.compare(0, prefix_.size(), prefix_) != 0)
      return std::nullopt;
    const std::string rest = name.substr(prefix_.size());
    if (rest[0] != 'a' || rest.size() > 10 ||
        !std::all_of(rest.begin() + 1, rest.end(), [](char c) { return c >= '0' && c <= '9'; })) {
      return std::nullopt;
    }
    const long id = std::stol(rest.substr(1));
    if (id > std::numeric_limits<AgentId>::max()) return std::nullopt;
    return static_cast<AgentId>(id);
  }

 private:
  std::string prefix_;
};

/// The orchestrator writes each world step's measurements as one MeasurementBlock sample per block of
/// consecutive agents, through one writer per block (partition "m<block>"). With one writer per agent,
/// every agent had to discover the hub's N + 2 endpoints: N (N + 2) announcements in all, which kept
/// N = 500 from ever starting (docs/scale.md, "measurement blocks"). At most kMaxMeasurementWriters
/// blocks; N <= 50 keeps one agent per block, i.e. one sample per agent per step as before. With DDS
/// Security each agent may read only its own partition m<i> (deploy/security/make-pki.sh), so no blocks.
inline constexpr int kMaxMeasurementWriters = 50;
inline int measurement_block_size(const config::Scenario& scenario, int agent_count) {
  if (!scenario.dds.security_dir.empty()) return 1;
  return std::max(1, (agent_count + kMaxMeasurementWriters - 1) / kMaxMeasurementWriters);
}
inline int measurement_block_count(int agent_count, int block_size) {
  return (agent_count + block_size - 1) / block_size;
}

inline dds_duration_t to_duration(double timeout_s) {
  if (!(timeout_s > 0.0)) {
    return 0;
  }
  if (!std::isfinite(timeout_s) || timeout_s > 1e9) {
    return DDS_INFINITY;
  }
  return static_cast<dds_duration_t>(std::llround(timeout_s * 1e9));
}

inline AgentId agent_id(AgentId self) {
  if (self < 0) {
    throw DdsError("AgentTransport: agent id " + std::to_string(self) + " is not an agent");
  }
  return self;
}

inline dds_entity_t create_participant(const DomainLease& domain) {
  return check(dds_create_participant(domain.domain_id(), nullptr, nullptr), "dds_create_participant");
}

inline dds_entity_t create_topic(dds_entity_t participant, const dds_topic_descriptor_t& descriptor,
                                 const char* name) {
  return check(dds_create_topic(participant, &descriptor, name, nullptr, nullptr), "dds_create_topic", name);
}

inline dds_entity_t create_publisher(dds_entity_t participant, const std::vector<std::string>& partitions) {
  const auto qos = partition_qos(partitions);
  return check(dds_create_publisher(participant, qos.get(), nullptr), "dds_create_publisher",
               partitions.front());
}

inline dds_entity_t create_subscriber(dds_entity_t participant, const std::vector<std::string>& partitions) {
  const auto qos = partition_qos(partitions);
  return check(dds_create_subscriber(participant, qos.get(), nullptr), "dds_create_subscriber",
               partitions.front());
}

inline dds_entity_t create_writer(dds_entity_t publisher, dds_entity_t topic,
                                  const config::QosSettings& settings, const char* what) {
  const auto qos = endpoint_qos(settings);
  return check(dds_create_writer(publisher, topic, qos.get(), nullptr), "dds_create_writer", what);
}

inline dds_entity_t create_reader(dds_entity_t subscriber, dds_entity_t topic,
                                  const config::QosSettings& settings, const char* what,
                                  const dds_listener_t* listener = nullptr) {
  const auto qos = endpoint_qos(settings);
  return check(dds_create_reader(subscriber, topic, qos.get(), listener), "dds_create_reader", what);
}

/// dds_write with the return code checked. A reliable write that times out (the history of a reliable
/// writer stayed full for max_blocking_time, i.e. a slow reader) drops that one sample instead of
/// failing the process: returns false.
inline bool write(dds_entity_t writer, const void* sample, const char* what) {
  const dds_return_t rc = dds_write(writer, sample);
  if (rc == DDS_RETCODE_TIMEOUT) {
    return false;
  }
  check(rc, "dds_write", what);
  return true;
}

/// Delivery latencies in constant memory: log-spaced buckets 2 % wide from 1 µs to ~3 s (a list of
/// samples grew an agent's RSS by ~2.4 KB/s). Quantiles are exact to the bucket width.
class LatencyHistogram {
 public:
  void add(std::int64_t latency_ns) {
    std::size_t bucket = 0;
    if (latency_ns > 1000) {
      const double steps = std::log(static_cast<double>(latency_ns) * 1e-3) / std::log(kRatio);
      bucket = std::min(kBuckets - 1, static_cast<std::size_t>(steps) + 1);
    }
    ++counts_[bucket];
    ++total_;
  }
  void clear() { *this = LatencyHistogram{}; }
  [[nodiscard]] std::uint64_t total() const { return total_; }
  /// The q-quantile in µs: the geometric middle of the bucket that holds it (bucket 0: ≤ 1 µs).
  [[nodiscard]] double quantile_us(double q) const {
    const auto rank = static_cast<std::uint64_t>(q * static_cast<double>(total_ - 1));
    std::uint64_t seen = 0;
    for (std::size_t bucket = 0; bucket < kBuckets; ++bucket) {
      seen += counts_[bucket];
      if (seen > rank) return bucket == 0 ? 1.0 : std::pow(kRatio, static_cast<double>(bucket) - 0.5);
    }
    return std::pow(kRatio, static_cast<double>(kBuckets) - 0.5);
  }

 private:
  static constexpr double kRatio = 1.02;
  static constexpr std::size_t kBuckets = 750;  // 1.02^750 µs ≈ 2.8 s; later samples land in the last
  std::array<std::uint64_t, kBuckets> counts_{};
  std::uint64_t total_ = 0;
};

/// Takes every sample a reader holds (loaned buffers, returned even if `handle` throws) and calls
/// handle(wire) — or handle(wire, source_timestamp_ns, taken_ns) if it takes three arguments — for each
/// valid one. Stops after a short batch so a busy writer cannot starve the caller.
/// With `latencies`, adds (now − source timestamp) of every valid sample to it.
template <typename Wire, typename Handle>
inline void take_all(dds_entity_t reader, Handle&& handle, LatencyHistogram* latencies = nullptr) {
  constexpr int32_t kBatch = 64;
  for (;;) {
    std::array<void*, kBatch> samples{};
    std::array<dds_sample_info_t, kBatch> infos{};
    const int32_t count = check(dds_take(reader, samples.data(), infos.data(), kBatch, kBatch), "dds_take");
    if (count <= 0) {
      return;
    }
    struct LoanGuard {
      dds_entity_t reader;
      void** buffer;
      int32_t count;
      ~LoanGuard() { static_cast<void>(dds_return_loan(reader, buffer, count)); }
    } guard{reader, samples.data(), count};
    constexpr bool kWantsTimes = std::is_invocable_v<Handle&, const Wire&, std::int64_t, std::int64_t>;
    const dds_time_t taken_at = (latencies != nullptr || kWantsTimes) ? dds_time() : 0;
    for (int32_t i = 0; i < count; ++i) {
      const dds_sample_info_t& info = infos[static_cast<std::size_t>(i)];
      if (info.valid_data) {
        if (latencies != nullptr && info.source_timestamp > 0)
          latencies->add(taken_at - info.source_timestamp);
        const auto& wire = *static_cast<const Wire*>(samples[static_cast<std::size_t>(i)]);
        if constexpr (kWantsTimes) {
          handle(wire, static_cast<std::int64_t>(info.source_timestamp), static_cast<std::int64_t>(taken_at));
        } else {
          handle(wire);
        }
      }
    }
    if (count < kBatch) {
      return;
    }
  }
}

inline dds_entity_t attach_reader(dds_entity_t waitset, dds_entity_t reader) {
  const dds_entity_t condition =
      check(dds_create_readcondition(reader, DDS_ANY_STATE), "dds_create_readcondition");
  check(dds_waitset_attach(waitset, condition, static_cast<dds_attach_t>(reader)), "dds_waitset_attach");
  return condition;
}

inline void wait(dds_entity_t waitset, double timeout_s) {
  check(dds_waitset_wait(waitset, nullptr, 0, to_duration(timeout_s)), "dds_waitset_wait");
}

/// (total_count, current_count) of a reader's matched writers: changes whenever a writer matches or
/// unmatches, so it tells when a cached view of the matched writers is stale. One status read, no copies.
inline std::pair<uint32_t, int32_t> matched_signature(dds_entity_t reader) {
  dds_subscription_matched_status_t status{};
  check(dds_get_subscription_matched_status(reader, &status), "dds_get_subscription_matched_status");
  return {status.total_count, static_cast<int32_t>(status.current_count)};
}

inline int32_t matched_count(dds_entity_t reader) { return matched_signature(reader).second; }

inline int32_t matched_reader_count(dds_entity_t writer) {
  dds_publication_matched_status_t status{};
  check(dds_get_publication_matched_status(writer, &status), "dds_get_publication_matched_status");
  return static_cast<int32_t>(status.current_count);
}

}  // namespace swarmloc::dds
