#include "qos.hpp"

#include <algorithm>
#include <cmath>

#include "swarmloc/dds/transport.hpp"

namespace swarmloc::dds {

namespace {

dds_duration_t seconds_or_infinity(double seconds) {
  if (!(seconds > 0.0) || !std::isfinite(seconds)) {
    return DDS_INFINITY;
  }
  return static_cast<dds_duration_t>(std::llround(seconds * 1e9));
}

}  // namespace

QosPtr endpoint_qos(const config::QosSettings& settings) {
  QosPtr qos(dds_create_qos());
  if (!qos) {
    throw DdsError("dds_create_qos: out of memory");
  }
  if (settings.reliability == config::Reliability::kReliable) {
    dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  } else {
    dds_qset_reliability(qos.get(), DDS_RELIABILITY_BEST_EFFORT, 0);
  }
  if (settings.history_depth > 0) {
    dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, settings.history_depth);
  } else {
    dds_qset_history(qos.get(), DDS_HISTORY_KEEP_ALL, DDS_LENGTH_UNLIMITED);
  }
  dds_qset_durability(qos.get(), settings.durability == config::Durability::kTransientLocal
                                     ? DDS_DURABILITY_TRANSIENT_LOCAL
                                     : DDS_DURABILITY_VOLATILE);
  dds_qset_deadline(qos.get(), seconds_or_infinity(settings.deadline_s));
  dds_qset_liveliness(qos.get(), DDS_LIVELINESS_AUTOMATIC, seconds_or_infinity(settings.liveliness_lease_s));
  return qos;
}

config::Scenario::Qos effective_qos(const config::Scenario& scenario) {
  config::Scenario::Qos qos = scenario.qos;
  if (scenario.run.mode != config::RunMode::kLockstep) return qos;
  for (config::QosSettings* family :
       {&qos.measurements, &qos.state, &qos.information, &qos.consensus, &qos.belief}) {
    family->reliability = config::Reliability::kReliable;
    family->history_depth = std::max(family->history_depth, 4);
  }
  return qos;
}

QosPtr partition_qos(const std::vector<std::string>& partitions) {
  QosPtr qos(dds_create_qos());
  if (!qos) {
    throw DdsError("dds_create_qos: out of memory");
  }
  std::vector<const char*> names;
  names.reserve(partitions.size());
  for (const auto& name : partitions) {
    names.push_back(name.c_str());
  }
  dds_qset_partition(qos.get(), static_cast<uint32_t>(names.size()), names.data());
  return qos;
}

}  // namespace swarmloc::dds
