#pragma once
// Which agents are alive and current at each world step (docs/robustness.md, "Liveness"). Pure
// bookkeeping: the orchestrator feeds it report arrivals, process exits and scheduled faults with its
// own clock's time, and scores only the agents it calls current.
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "swarmloc/core/types.hpp"

namespace swarmloc::runtime {

struct LivenessEvent {
  enum class Kind { kDied, kStalled, kResumed };
  AgentId agent = 0;
  Kind kind = Kind::kDied;
  std::int64_t step = 0;
  double time_s = 0.0;  ///< since the tracker's time origin (the orchestrator's start)
  std::string reason;
};
const char* to_string(LivenessEvent::Kind kind);

struct LivenessLimits {
  /// An estimate older than this is not scored as current (free run: a few world periods).
  double current_s = std::numeric_limits<double>::infinity();
  /// No report for this long: the agent is stalled (logged; an unscheduled stall degrades the run).
  double stall_s = 2.0;
  /// After a scheduled restart, this long to report again before it counts as stalled (start-up).
  double restart_grace_s = 60.0;
};

class LivenessTracker {
 public:
  LivenessTracker(int agents, LivenessLimits limits);

  /// A report from `agent` arrived at `now_s`.
  void heard(AgentId agent, std::int64_t step, double now_s);
  /// `agent`'s process ended outside the fault schedule; exit_status: exit code or 128 + signal.
  void exited(AgentId agent, std::int64_t step, double now_s, int exit_status);
  /// faults.kill / faults.pause took `agent` down: expected silence, no event, not scored.
  void scheduled_down(AgentId agent);
  /// faults.kill restart / faults.pause resume at `now_s`: expected back within the grace (restart) or
  /// the stall limit (resume).
  void scheduled_up(AgentId agent, double now_s, bool restarted);
  /// START went out at `now_s`: an agent that said hello is silent until then by design (it stops
  /// repeating its hello once the orchestrator has it), so its stall limit runs from now.
  void started(double now_s);
  /// Finds stalls and resumptions at world step `step`.
  void check(std::int64_t step, double now_s);
  /// The run is over at `now_s`; its last step is judged at `judged_s`. Every alive agent the final step
  /// cannot score is stalled now, however much of its grace is left: one not heard since it was started,
  /// restarted or resumed, one without an estimate to score (`has_estimate[agent]` false: a restarted
  /// process that said hello but ran no step), or one whose newest report is not current at `judged_s`.
  /// A run must not end healthy with an agent it expected up and did not score.
  void close(std::int64_t step, double judged_s, double now_s, const std::vector<bool>& has_estimate);

  /// Alive, not down, not stalled, and its newest report no older than LivenessLimits::current_s.
  [[nodiscard]] bool current(AgentId agent, double now_s) const;
  /// Dead or stalled now (unscheduled): scored as missing and counted apart.
  [[nodiscard]] int lost_count() const;
  [[nodiscard]] int deaths() const { return deaths_; }
  [[nodiscard]] int stalls() const { return stalls_; }
  [[nodiscard]] const std::vector<LivenessEvent>& events() const { return events_; }

  /// agents.csv's view of one agent: "ok", "died" or "stalled" (its last unscheduled loss), with the
  /// step and the reason.
  struct Fate {
    std::string status = "ok";
    std::int64_t step = -1;
    std::string reason;
  };
  [[nodiscard]] Fate fate(AgentId agent) const;

  /// summary.json's `liveness` block.
  [[nodiscard]] nlohmann::json to_json() const;

 private:
  enum class State { kAlive, kDown, kDead, kStalled };
  struct Agent {
    State state = State::kAlive;
    std::optional<double> last_heard_s;
    double silent_since_s = 0.0;  ///< start of the current expected-silence allowance
    double allowance_s = 0.0;     ///< how long silence is fine from silent_since_s
  };
  void record(AgentId agent, LivenessEvent::Kind kind, std::int64_t step, double now_s, std::string reason);

  LivenessLimits limits_;
  std::vector<Agent> agents_;
  std::vector<LivenessEvent> events_;
  int deaths_ = 0;
  int stalls_ = 0;
};

/// "exit status 1" / "killed by signal 9 (Killed)" from an exit code or 128 + signal.
std::string describe_exit(int exit_status);

}  // namespace swarmloc::runtime
