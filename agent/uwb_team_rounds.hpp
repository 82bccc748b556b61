#pragma once
// The two rounds a vehicle of a MURP UWB team runs per window (docs/real-data.md, "MURP over DDS"), without
// the transport: on its window input it publishes its sensing; with every teammate's sensing of that window
// it observes its own ranges and publishes its own-range estimates; with every teammate's own-range
// estimates it fuses and publishes what it reports. A teammate that stays silent for round_timeout_s is
// given up on for that round (counted). Samples may arrive in any order and ahead of their window.
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <vector>

#include "swarmloc/dds/uwb_team_io.hpp"
#include "swarmloc/estimators/uwb/team_member.hpp"

namespace swarmloc::agent {

/// Where the rounds' samples go (the DDS writers, or a test's lists).
struct UwbTeamPort {
  std::function<void(const dds::UwbSensing&)> publish_sensing;
  std::function<void(const dds::UwbEstimates&)> publish_estimates;
};

struct UwbRoundCounters {
  std::uint64_t windows = 0;
  std::uint64_t missing_sensing = 0;    ///< teammates whose sensing did not come within the timeout
  std::uint64_t missing_estimates = 0;  ///< teammates whose own-range estimates did not
  std::uint64_t late_samples = 0;       ///< for a window already done (dropped)
};

class UwbTeamRounds {
 public:
  UwbTeamRounds(estimators::uwb::TeamMember member, const std::vector<AgentId>& team, bool cooperate,
                double round_timeout_s, UwbTeamPort port);

  /// Buffers what arrived (the vehicle's own samples are not expected here).
  void take(const dds::UwbVehicleInbound& inbound);
  /// Runs every round that can run at `now_s` (seconds on any monotonic clock), publishing as it goes.
  void advance(double now_s);

  [[nodiscard]] bool stopped() const { return stopped_; }
  /// The last window whose fused estimates were published (−1: none yet).
  [[nodiscard]] std::int64_t windows_done() const { return done_; }
  [[nodiscard]] const UwbRoundCounters& counters() const { return counters_; }

 private:
  enum class Phase { kAwaitInput, kAwaitSensing, kAwaitOwn };
  bool start_window(double now_s);
  bool observe(double now_s);
  bool fuse(double now_s);
  /// Teammates not yet heard from in `heard` (a map keyed by teammate), counted into `missing` once the
  /// round's deadline has passed. True when the round may run.
  template <typename Heard>
  bool round_ready(const Heard& heard, double now_s, std::uint64_t& missing) const;

  estimators::uwb::TeamMember member_;
  std::vector<AgentId> teammates_;
  bool cooperate_;
  double round_timeout_s_;
  UwbTeamPort port_;

  Phase phase_ = Phase::kAwaitInput;
  double deadline_s_ = 0.0;
  std::int64_t done_ = -1;
  bool stopped_ = false;
  std::optional<dds::UwbWindowInput> current_;
  std::map<std::int64_t, dds::UwbWindowInput> inputs_;
  std::map<std::int64_t, std::map<AgentId, std::optional<estimators::uwb::VehicleSensing>>> sensing_;
  std::map<std::int64_t, std::map<AgentId, std::map<AgentId, estimators::uwb::PoseEstimate>>> own_;
  UwbRoundCounters counters_;
};

}  // namespace swarmloc::agent
