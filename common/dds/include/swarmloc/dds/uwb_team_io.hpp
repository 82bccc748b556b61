#pragma once
// The topics of a MURP UWB team over DDS (docs/real-data.md, "MURP over DDS"): the orchestrator writes each
// vehicle its window of data (swarmloc_uwb_window), the vehicles write their IMU readings
// (swarmloc_uwb_sensing) and their estimates of each other (swarmloc_uwb_estimates: own-range, then fused).
// Plain types here; the IDL samples stay in common/dds/src. Every received sample is checked (the team
// roster, finite numbers, consistent sizes, symmetric covariances); a sample that fails is dropped and
// counted, never used.
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/estimators/uwb/team_member.hpp"

namespace swarmloc::dds {

/// Orchestrator -> one vehicle: one window of its own data, or the end of the run.
struct UwbWindowInput {
  AgentId vehicle = 0;
  std::int64_t window = 0;
  double time_s = 0.0;
  double dt_s = 0.0;
  bool stop = false;
  /// The vehicle's IMU and altimeter; nullopt: it has no pose in this window (it observes nothing).
  std::optional<estimators::uwb::VehicleSensing> sensing;
  std::vector<estimators::uwb::PeerRanges> ranges;
};

/// Vehicle -> team: its reading of one window (nullopt: it has none).
struct UwbSensing {
  AgentId vehicle = 0;
  std::int64_t window = 0;
  std::optional<estimators::uwb::VehicleSensing> sensing;
};

enum class UwbRound : std::uint8_t {
  kHello = 0,  ///< window −1, no estimates: every endpoint of the sender is matched both ways
  kOwn = 1,    ///< from the sender's own ranges: what its teammates fuse
  kFused = 2,  ///< what the sender reports
};

/// Vehicle -> team and orchestrator: its estimates of its peers (in its level frame) in one round.
struct UwbEstimates {
  AgentId vehicle = 0;
  std::int64_t window = 0;
  UwbRound round = UwbRound::kOwn;
  std::map<AgentId, estimators::uwb::PoseEstimate> peers;
};

/// Who a participant is: a vehicle of `team`, or (vehicle = kOrchestratorId) the orchestrator.
struct UwbTeamEndpoint {
  int domain_id = 0;
  std::vector<AgentId> team;  ///< every vehicle, each once (at most 8)
  AgentId vehicle = kOrchestratorId;
};

/// Samples through one participant. Rejected samples broke a rule of uwb_team_io.hpp (counted by reason);
/// ignored ones were well-formed but not for us (another vehicle's window input, our own samples).
struct UwbTeamCounters {
  std::uint64_t sent = 0;
  std::uint64_t write_timeouts = 0;  ///< reliable writes dropped after blocking 100 ms (a stalled reader)
  std::uint64_t received = 0;        ///< accepted
  std::uint64_t ignored = 0;
  std::uint64_t rejected = 0;
  std::map<std::string, std::uint64_t> rejected_by_reason;
  std::uint64_t ros2_sent = 0;            ///< ROS 2 samples (the orchestrator with ros2 on)
  std::uint64_t ros2_write_timeouts = 0;  ///< ROS 2 writes dropped after blocking 100 ms
};

/// One window's relative poses as the orchestrator publishes them on ROS 2 (docs/ros2.md, "MURP relative
/// poses"): every observer's reported estimate of every peer, and the truth the run scores them against.
struct UwbRos2Window {
  double time_s = 0.0;  ///< the window's trial time: the stamp of every sample
  /// Each vehicle's roll and pitch (its IMU's) in this window: a peer's orientation in an observer's level
  /// frame is Rz(ψ)·Ry(pitch)·Rx(roll). A vehicle missing here: roll = pitch = 0.
  std::map<AgentId, estimators::uwb::Tilt> tilts;
  std::map<std::pair<AgentId, AgentId>, estimators::uwb::PoseEstimate> estimates;  ///< (observer, peer)
  std::map<std::pair<AgentId, AgentId>, estimators::uwb::RelativePose> truth;      ///< (observer, peer)
};

/// The scenario whose DDS keys the team's participants use: `domain_id`, fixed ports with vehicle k of the
/// sorted roster in slot k and the orchestrator in slot team_size (cyclone_config), lockstep heartbeats.
config::Scenario uwb_team_scenario(int domain_id, int team_size);

struct UwbVehicleInbound {
  std::vector<UwbWindowInput> inputs;   ///< addressed to this vehicle
  std::vector<UwbSensing> sensing;      ///< teammates'
  std::vector<UwbEstimates> estimates;  ///< teammates'
};

/// A vehicle's side: reads its window inputs and its teammates' sensing and estimates, writes its own.
class UwbVehicleIo {
 public:
  /// Throws DdsError (transport.hpp) when DDS fails, std::invalid_argument for a bad roster.
  explicit UwbVehicleIo(const UwbTeamEndpoint& endpoint);
  ~UwbVehicleIo();
  UwbVehicleIo(const UwbVehicleIo&) = delete;
  UwbVehicleIo& operator=(const UwbVehicleIo&) = delete;

  void publish_sensing(const UwbSensing& sensing);
  void publish_estimates(const UwbEstimates& estimates);
  /// Blocks up to timeout_s or until a sample arrives, then takes everything received.
  UwbVehicleInbound wait_and_take(double timeout_s);
  /// The orchestrator's window writer and every teammate's writers match our readers, and our writers
  /// every teammate's readers and the orchestrator's estimate reader: nothing written now is missed.
  [[nodiscard]] bool matched_both_ways() const;
  [[nodiscard]] UwbTeamCounters counters() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The orchestrator's side: writes window inputs, reads every vehicle's estimates; with `ros2`, also
/// writes every ordered pair's relative pose and its truth on ROS 2 topics (docs/ros2.md, "MURP relative
/// poses"; without it no ROS entity is created).
class UwbOrchestratorIo {
 public:
  explicit UwbOrchestratorIo(const UwbTeamEndpoint& endpoint, bool ros2 = false);
  ~UwbOrchestratorIo();
  UwbOrchestratorIo(const UwbOrchestratorIo&) = delete;
  UwbOrchestratorIo& operator=(const UwbOrchestratorIo&) = delete;

  void publish_window(const UwbWindowInput& input);
  /// Blocks up to timeout_s or until a sample arrives, then takes every accepted estimates sample.
  std::vector<UwbEstimates> wait_and_take_estimates(double timeout_s);
  /// Every vehicle's window reader and estimates writer are matched to ours.
  [[nodiscard]] bool matched() const;
  /// With ros2: each estimate on rt/swarmloc/murp/vehicle_<observer>/vehicle_<peer>/pose, each truth on
  /// …/truth. Pairs off the roster are skipped. Without ros2: nothing.
  void publish_ros2_window(const UwbRos2Window& window);
  /// ROS 2 readers matched to the ROS 2 writers, summed over the writers (one per subscriber and topic; 0
  /// without ros2).
  [[nodiscard]] int ros2_matched_readers() const;
  [[nodiscard]] UwbTeamCounters counters() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace swarmloc::dds
