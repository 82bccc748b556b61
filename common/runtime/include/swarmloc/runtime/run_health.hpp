#pragma once
// Run health (docs/robustness.md, "Run health"): each DDS agent measures its own timing against its
// clock (HealthMeter), the orchestrator measures its world steps, and assess_health() turns the figures
// and the liveness events into a verdict. A degraded run completed, but its results are not
// representative of the configured system; `swarmloc run` then exits 3.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "swarmloc/runtime/envelope.hpp"

namespace swarmloc::runtime {

/// An agent's timing figures, accumulated as its process runs (pure: the caller reads the clock).
class HealthMeter {
 public:
  explicit HealthMeter(double period_s) : period_s_(period_s) {}
  /// A step that started `lateness_s` after its time, `missed` whole periods skipped before it.
  void on_tick(double lateness_s, std::uint32_t missed);
  /// A measurement batch arrived; `earlier_waiting`: a batch before it has not been used yet.
  void on_batch(bool earlier_waiting);
  /// A step used a batch that arrived `wait_s` before.
  void on_batch_used(double wait_s);
  /// At a step: the age of each neighbour's newest sample.
  void on_neighbour_age(double age_s);
  [[nodiscard]] const AgentHealth& figures() const { return figures_; }

 private:
  double period_s_;
  double lateness_sum_s_ = 0.0;
  double age_sum_s_ = 0.0;
  std::uint64_t ages_ = 0;
  AgentHealth figures_;
};

/// What the orchestrator saw of the run as a whole.
struct RunHealthInput {
  bool free_run = true;  ///< lockstep and in-process runs have no real-time schedule to miss
  double rate_hz = 10.0;
  std::int64_t world_steps = 0;
  double world_steps_s = 0.0;         ///< START to the last world step
  std::int64_t late_world_steps = 0;  ///< published more than half a period late
  double max_world_step_lateness_s = 0.0;
  int unscheduled_deaths = 0;
  int stalls = 0;
  int lockstep_timeouts = 0;
  std::size_t non_finite_steps = 0;  ///< steps scored with a NaN/Inf estimate (metrics.hpp ErrorStats)
  std::vector<AgentHealth> agents;   ///< one per agent that reported
};

/// Limits of a healthy run (docs/robustness.md).
inline constexpr double kMaxLateTickFraction = 0.05;       ///< of all agents' ticks, late by > period / 2
inline constexpr double kMinWorldRateFraction = 0.95;      ///< achieved world rate / run.rate_hz
inline constexpr double kMaxLateWorldStepFraction = 0.05;  ///< orchestrator steps late by > period / 2

struct RunHealth {
  bool healthy = true;
  std::vector<std::string> reasons;  ///< why degraded (empty when healthy)
  nlohmann::json figures = nlohmann::json::object();
};

RunHealth assess_health(const RunHealthInput& input);

/// summary.json's `health` block: {verdict, reasons, figures}.
nlohmann::json to_json(const RunHealth& health);

}  // namespace swarmloc::runtime
