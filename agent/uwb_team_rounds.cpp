#include "uwb_team_rounds.hpp"

#include <algorithm>
#include <utility>

namespace swarmloc::agent {
namespace uwb = estimators::uwb;

UwbTeamRounds::UwbTeamRounds(uwb::TeamMember member, const std::vector<AgentId>& team, bool cooperate,
                             double round_timeout_s, UwbTeamPort port)
    : member_(std::move(member)),
      cooperate_(cooperate),
      round_timeout_s_(round_timeout_s),
      port_(std::move(port)) {
  for (const AgentId vehicle : team) {
    if (vehicle != member_.id()) teammates_.push_back(vehicle);
  }
}

void UwbTeamRounds::take(const dds::UwbVehicleInbound& inbound) {
  for (const auto& input : inbound.inputs) {
    if (input.stop) {
      stopped_ = true;  // the orchestrator stops only between windows, after every report of the last one
    } else if (input.window <= done_ || (current_ && input.window <= current_->window)) {
      ++counters_.late_samples;  // a window never runs twice
    } else {
      inputs_.insert_or_assign(input.window, input);
    }
  }
  for (const auto& sensing : inbound.sensing) {
    if (sensing.window <= done_) {
      ++counters_.late_samples;
    } else {
      sensing_[sensing.window][sensing.vehicle] = sensing.sensing;
    }
  }
  for (const auto& estimates : inbound.estimates) {
    if (estimates.round != dds::UwbRound::kOwn)
      continue;  // fused ones are for the orchestrator, hellos for nobody
    if (estimates.window <= done_) {
      ++counters_.late_samples;
    } else {
      own_[estimates.window][estimates.vehicle] = estimates.peers;
    }
  }
}

void UwbTeamRounds::advance(double now_s) {
  for (bool progressed = true; progressed && !stopped_;) {
    switch (phase_) {
      case Phase::kAwaitInput:
        progressed = start_window(now_s);
        break;
      case Phase::kAwaitSensing:
        progressed = observe(now_s);
        break;
      case Phase::kAwaitOwn:
        progressed = fuse(now_s);
        break;
    }
  }
}

bool UwbTeamRounds::start_window(double now_s) {
  if (inputs_.empty()) return false;
  current_ = std::move(inputs_.begin()->second);
  inputs_.erase(inputs_.begin());
  port_.publish_sensing({member_.id(), current_->window, current_->sensing});
  phase_ = Phase::kAwaitSensing;
  deadline_s_ = now_s + round_timeout_s_;
  return true;
}

template <typename Heard>
bool UwbTeamRounds::round_ready(const Heard& heard, double now_s, std::uint64_t& missing) const {
  const auto silent = static_cast<std::uint64_t>(
      std::count_if(teammates_.begin(), teammates_.end(),
                    [&heard](AgentId teammate) { return !heard.contains(teammate); }));
  if (silent == 0) return true;
  if (now_s < deadline_s_) return false;
  missing += silent;  // proceed with what arrived
  return true;
}

bool UwbTeamRounds::observe(double now_s) {
  const auto& heard = sensing_[current_->window];
  if (!round_ready(heard, now_s, counters_.missing_sensing)) return false;
  dds::UwbEstimates own{member_.id(), current_->window, dds::UwbRound::kOwn, {}};
  // A vehicle with no pose in this window observes nothing and adds nothing to its teammates' fusion.
  if (current_->sensing) {
    std::map<AgentId, uwb::VehicleSensing> peers;
    for (const auto& [teammate, sensing] : heard) {
      if (sensing) peers.emplace(teammate, *sensing);
    }
    own.peers = member_.observe(current_->dt_s, *current_->sensing, peers, current_->ranges);
  }
  port_.publish_estimates(own);
  phase_ = Phase::kAwaitOwn;
  deadline_s_ = now_s + round_timeout_s_;
  return true;
}

bool UwbTeamRounds::fuse(double now_s) {
  const std::int64_t window = current_->window;
  const auto& heard = own_[window];
  if (!round_ready(heard, now_s, counters_.missing_estimates)) return false;
  std::vector<uwb::PeerRelation> relations;
  for (const auto& [teammate, estimates] : heard) {
    for (const auto& [peer, estimate] : estimates) relations.push_back({teammate, peer, estimate});
  }
  port_.publish_estimates({member_.id(), window, dds::UwbRound::kFused,
                           cooperate_ ? member_.fuse(relations) : member_.own_estimates()});
  done_ = window;
  ++counters_.windows;
  current_.reset();
  sensing_.erase(sensing_.begin(), sensing_.upper_bound(window));
  own_.erase(own_.begin(), own_.upper_bound(window));
  phase_ = Phase::kAwaitInput;
  return true;
}

}  // namespace swarmloc::agent
