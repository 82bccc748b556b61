// The UWB team's participants (uwb_team_io.hpp, docs/real-data.md, "MURP over DDS").
#include "swarmloc/dds/uwb_team_io.hpp"

#include <algorithm>
#include <stdexcept>

#include "endpoints.hpp"
#include "ros2_bridge.hpp"
#include "uwb_team_wire.hpp"

namespace swarmloc::dds {
namespace {

constexpr const char* kTopicUwbWindow = "swarmloc_uwb_window";
constexpr const char* kTopicUwbSensing = "swarmloc_uwb_sensing";
constexpr const char* kTopicUwbEstimates = "swarmloc_uwb_estimates";
/// Keep-last per vehicle (each topic is keyed by vehicle): a window puts at most two samples of a vehicle on
/// a topic, and lockstep keeps the team within a window or two of each other, so nothing is ever pushed out.
constexpr int kUwbHistoryDepth = 64;

/// Reliable, volatile (the orchestrator starts only once every endpoint is matched), and blind to this
/// participant's own writers: a vehicle never reads back its own sensing or estimates.
QosPtr uwb_qos() {
  config::QosSettings settings;
  settings.reliability = config::Reliability::kReliable;
  settings.history_depth = kUwbHistoryDepth;
  settings.durability = config::Durability::kVolatile;
  QosPtr qos = endpoint_qos(settings);
  dds_qset_ignorelocal(qos.get(), DDS_IGNORELOCAL_PARTICIPANT);
  return qos;
}

std::vector<AgentId> checked_team(const UwbTeamEndpoint& endpoint) {
  std::vector<AgentId> team = endpoint.team;
  std::sort(team.begin(), team.end());
  const bool unique = std::adjacent_find(team.begin(), team.end()) == team.end();
  if (team.empty() || team.size() > uwb_codec::kMaxTeam || !unique || team.front() < 0) {
    throw std::invalid_argument("uwb team: the roster must hold 1-8 distinct non-negative vehicle ids");
  }
  if (endpoint.vehicle != kOrchestratorId &&
      !std::binary_search(team.begin(), team.end(), endpoint.vehicle)) {
    throw std::invalid_argument("uwb team: vehicle " + std::to_string(endpoint.vehicle) +
                                " is not on the team");
  }
  return team;
}

/// Vehicle k of the sorted roster takes discovery slot k, the orchestrator slot team size (cyclone_config).
Topology uwb_topology(const std::vector<AgentId>& team, AgentId vehicle) {
  const int size = static_cast<int>(team.size());
  if (vehicle == kOrchestratorId) return Topology{kOrchestratorId, size, {}};
  Topology topology{
      static_cast<AgentId>(std::find(team.begin(), team.end(), vehicle) - team.begin()), size, {}};
  for (int slot = 0; slot < size; ++slot) {
    if (slot != topology.self) topology.neighbours.push_back(slot);
  }
  return topology;
}

int others(const std::vector<AgentId>& team) { return static_cast<int>(team.size()) - 1; }

}  // namespace

/// What both sides share (outside the anonymous namespace: the Impls derive from it): the domain, the
/// participant, the three topics and a waitset over the readers.
struct UwbParticipant {
  explicit UwbParticipant(const UwbTeamEndpoint& endpoint)
      : team(checked_team(endpoint)),
        self(endpoint.vehicle),
        domain(static_cast<dds_domainid_t>(endpoint.domain_id),
               cyclone_config(uwb_team_scenario(endpoint.domain_id, static_cast<int>(team.size())),
                              uwb_topology(team, endpoint.vehicle))),
        participant(create_participant(domain)),
        window_topic(create_topic(participant.get(), swarmloc_uwb_WindowInput_desc, kTopicUwbWindow)),
        sensing_topic(create_topic(participant.get(), swarmloc_uwb_Sensing_desc, kTopicUwbSensing)),
        estimates_topic(create_topic(participant.get(), swarmloc_uwb_Estimates_desc, kTopicUwbEstimates)),
        waitset(check(dds_create_waitset(participant.get()), "dds_create_waitset")) {}

  dds_entity_t writer(dds_entity_t topic, const char* what) const {
    return check(dds_create_writer(participant.get(), topic, uwb_qos().get(), nullptr), "dds_create_writer",
                 what);
  }
  dds_entity_t reader(dds_entity_t topic, const char* what) const {
    const dds_entity_t handle = check(dds_create_reader(participant.get(), topic, uwb_qos().get(), nullptr),
                                      "dds_create_reader", what);
    attach_reader(waitset, handle);
    return handle;
  }
  void send(dds_entity_t writer, const void* sample, const char* what) {
    if (write(writer, sample, what)) {
      ++counters.sent;
    } else {
      ++counters.write_timeouts;
    }
  }
  /// Counts a taken sample: accepted (true), or rejected for `problem`.
  bool admit(uwb_codec::Problem problem) {
    if (problem == nullptr) return true;
    ++counters.rejected;
    ++counters.rejected_by_reason[problem];
    return false;
  }

  std::vector<AgentId> team;  ///< sorted
  AgentId self;
  DomainLease domain;  // declared before the participant: released after it
  Entity participant;
  dds_entity_t window_topic;
  dds_entity_t sensing_topic;
  dds_entity_t estimates_topic;
  dds_entity_t waitset;
  UwbTeamCounters counters;
};

config::Scenario uwb_team_scenario(int domain_id, int team_size) {
  config::Scenario scenario;
  scenario.dds.domain_id = domain_id;
  scenario.world.agents = team_size;
  // Lockstep's 5 ms heartbeats: a lost sample is repaired within a round, not after 300 ms.
  scenario.run.mode = config::RunMode::kLockstep;
  return scenario;
}

// ===================================================================================================
// Vehicle

struct UwbVehicleIo::Impl : UwbParticipant {
  explicit Impl(const UwbTeamEndpoint& endpoint)
      : UwbParticipant(endpoint),
        window_reader(reader(window_topic, kTopicUwbWindow)),
        sensing_writer(writer(sensing_topic, kTopicUwbSensing)),
        sensing_reader(reader(sensing_topic, kTopicUwbSensing)),
        estimates_writer(writer(estimates_topic, kTopicUwbEstimates)),
        estimates_reader(reader(estimates_topic, kTopicUwbEstimates)) {}

  dds_entity_t window_reader;
  dds_entity_t sensing_writer;
  dds_entity_t sensing_reader;
  dds_entity_t estimates_writer;
  dds_entity_t estimates_reader;
};

UwbVehicleIo::UwbVehicleIo(const UwbTeamEndpoint& endpoint) : impl_(std::make_unique<Impl>(endpoint)) {}
UwbVehicleIo::~UwbVehicleIo() = default;

void UwbVehicleIo::publish_sensing(const UwbSensing& sensing) {
  const auto sample = wire_sensing(sensing);
  impl_->send(impl_->sensing_writer, &sample, kTopicUwbSensing);
}

void UwbVehicleIo::publish_estimates(const UwbEstimates& estimates) {
  const WireEstimates wire(estimates);
  impl_->send(impl_->estimates_writer, &wire.sample, kTopicUwbEstimates);
}

UwbVehicleInbound UwbVehicleIo::wait_and_take(double timeout_s) {
  Impl& io = *impl_;
  wait(io.waitset, timeout_s);
  UwbVehicleInbound inbound;
  take_all<swarmloc_uwb_WindowInput>(io.window_reader, [&](const swarmloc_uwb_WindowInput& wire) {
    UwbWindowInput input;
    if (!io.admit(accept(wire, io.team, input))) return;
    if (input.vehicle != io.self) {
      ++io.counters.ignored;  // another vehicle's window: the topic is shared, its key tells whose
      return;
    }
    ++io.counters.received;
    inbound.inputs.push_back(std::move(input));
  });
  take_all<swarmloc_uwb_Sensing>(io.sensing_reader, [&](const swarmloc_uwb_Sensing& wire) {
    UwbSensing sensing;
    if (!io.admit(accept(wire, io.team, sensing))) return;
    ++(sensing.vehicle == io.self ? io.counters.ignored : io.counters.received);
    if (sensing.vehicle != io.self) inbound.sensing.push_back(sensing);
  });
  take_all<swarmloc_uwb_Estimates>(io.estimates_reader, [&](const swarmloc_uwb_Estimates& wire) {
    UwbEstimates estimates;
    if (!io.admit(accept(wire, io.team, estimates))) return;
    ++(estimates.vehicle == io.self ? io.counters.ignored : io.counters.received);
    if (estimates.vehicle != io.self) inbound.estimates.push_back(std::move(estimates));
  });
  return inbound;
}

bool UwbVehicleIo::matched_both_ways() const {
  const Impl& io = *impl_;
  const int teammates = others(io.team);
  return matched_count(io.window_reader) >= 1 && matched_reader_count(io.sensing_writer) >= teammates &&
         matched_count(io.sensing_reader) >= teammates &&
         matched_reader_count(io.estimates_writer) >= teammates + 1 &&  // + the orchestrator
         matched_count(io.estimates_reader) >= teammates;
}

UwbTeamCounters UwbVehicleIo::counters() const { return impl_->counters; }

// ===================================================================================================
// Orchestrator

struct UwbOrchestratorIo::Impl : UwbParticipant {
  Impl(const UwbTeamEndpoint& endpoint, bool ros2)
      : UwbParticipant(endpoint),
        window_writer(writer(window_topic, kTopicUwbWindow)),
        estimates_reader(reader(estimates_topic, kTopicUwbEstimates)) {
    if (!ros2) return;
    for (const AgentId observer : team) {
      for (const AgentId peer : team) {
        if (peer == observer) continue;
        ros2_writers[{observer, peer}] = {
            ros2::create_writer(participant.get(), geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc,
                                ros2::murp_pose_topic(observer, peer)),
            ros2::create_writer(participant.get(), geometry_msgs_msg_dds__PoseStamped__desc,
                                ros2::murp_truth_topic(observer, peer))};
      }
    }
  }

  void send_ros2(dds_entity_t writer, const void* sample, const char* what) {
    if (write(writer, sample, what)) {
      ++counters.ros2_sent;
    } else {
      ++counters.ros2_write_timeouts;
    }
  }

  dds_entity_t window_writer;
  dds_entity_t estimates_reader;
  struct Ros2Writers {
    dds_entity_t pose = 0;
    dds_entity_t truth = 0;
  };
  std::map<std::pair<AgentId, AgentId>, Ros2Writers> ros2_writers;  ///< (observer, peer); empty: ros2 off
};

UwbOrchestratorIo::UwbOrchestratorIo(const UwbTeamEndpoint& endpoint, bool ros2)
    : impl_(std::make_unique<Impl>(UwbTeamEndpoint{endpoint.domain_id, endpoint.team, kOrchestratorId},
                                   ros2)) {}
UwbOrchestratorIo::~UwbOrchestratorIo() = default;

void UwbOrchestratorIo::publish_window(const UwbWindowInput& input) {
  const WireWindowInput wire(input);
  impl_->send(impl_->window_writer, &wire.sample, kTopicUwbWindow);
}

std::vector<UwbEstimates> UwbOrchestratorIo::wait_and_take_estimates(double timeout_s) {
  Impl& io = *impl_;
  wait(io.waitset, timeout_s);
  std::vector<UwbEstimates> taken;
  take_all<swarmloc_uwb_Estimates>(io.estimates_reader, [&](const swarmloc_uwb_Estimates& wire) {
    UwbEstimates estimates;
    if (!io.admit(accept(wire, io.team, estimates))) return;
    ++io.counters.received;
    taken.push_back(std::move(estimates));
  });
  return taken;
}

bool UwbOrchestratorIo::matched() const {
  const auto vehicles = static_cast<int>(impl_->team.size());
  return matched_reader_count(impl_->window_writer) >= vehicles &&
         matched_count(impl_->estimates_reader) >= vehicles;
}

void UwbOrchestratorIo::publish_ros2_window(const UwbRos2Window& window) {
  Impl& io = *impl_;
  if (io.ros2_writers.empty()) return;
  const auto tilt_of = [&window](AgentId vehicle) {
    const auto found = window.tilts.find(vehicle);
    return found != window.tilts.end() ? found->second : estimators::uwb::Tilt{};
  };
  for (const auto& [pair, estimate] : window.estimates) {
    const auto writers = io.ros2_writers.find(pair);
    if (writers == io.ros2_writers.end()) continue;
    const ros2::WireRelativePose wire(pair.first, window.time_s, estimate, tilt_of(pair.second));
    io.send_ros2(writers->second.pose, &wire.sample, "ROS 2 MURP pose");
  }
  for (const auto& [pair, truth] : window.truth) {
    const auto writers = io.ros2_writers.find(pair);
    if (writers == io.ros2_writers.end()) continue;
    const ros2::WireRelativeTruth wire(pair.first, window.time_s, truth, tilt_of(pair.second));
    io.send_ros2(writers->second.truth, &wire.sample, "ROS 2 MURP truth");
  }
}

int UwbOrchestratorIo::ros2_matched_readers() const {
  int readers = 0;
  for (const auto& [pair, writers] : impl_->ros2_writers)
    readers += matched_reader_count(writers.pose) + matched_reader_count(writers.truth);
  return readers;
}

UwbTeamCounters UwbOrchestratorIo::counters() const { return impl_->counters; }

}  // namespace swarmloc::dds
