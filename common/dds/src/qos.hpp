#pragma once
// QosSettings (scenario.qos.<family>) -> Cyclone QoS objects.
#include <dds/dds.h>

#include <memory>
#include <string>
#include <vector>

#include "swarmloc/config/scenario.hpp"

namespace swarmloc::dds {

struct QosDeleter {
  void operator()(dds_qos_t* qos) const { dds_delete_qos(qos); }
};
using QosPtr = std::unique_ptr<dds_qos_t, QosDeleter>;

/// Reader/writer QoS for one topic family: reliability (reliable writes block at most 100 ms),
/// history keep-last depth (depth <= 0: keep-all), durability, deadline and automatic liveliness
/// (0 s = infinite for both).
QosPtr endpoint_qos(const config::QosSettings& settings);

/// The QoS a run actually uses: scenario.qos, except in run.mode = lockstep, where every
/// inter-agent family and the measurements become reliable with keep-last ≥ 4 — lockstep's barrier
/// relies on every sample arriving, and a neighbour may be one step ahead when we take.
config::Scenario::Qos effective_qos(const config::Scenario& scenario);

/// Publisher/subscriber QoS with the given partition names (must not be empty).
QosPtr partition_qos(const std::vector<std::string>& partitions);

}  // namespace swarmloc::dds
