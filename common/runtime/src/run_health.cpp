#include "swarmloc/runtime/run_health.hpp"

#include <algorithm>
#include <cstdio>

namespace swarmloc::runtime {

void HealthMeter::on_tick(double lateness_s, std::uint32_t missed) {
  lateness_s = std::max(0.0, lateness_s);
  ++figures_.ticks;
  if (lateness_s > 0.5 * period_s_) ++figures_.late_ticks;
  figures_.missed_ticks += missed;
  figures_.max_tick_lateness_s = std::max(figures_.max_tick_lateness_s, lateness_s);
  lateness_sum_s_ += lateness_s;
  figures_.mean_tick_lateness_s = lateness_sum_s_ / static_cast<double>(figures_.ticks);
}

void HealthMeter::on_batch(bool earlier_waiting) {
  ++figures_.batches_received;
  if (earlier_waiting) ++figures_.batches_merged;
}

void HealthMeter::on_batch_used(double wait_s) {
  figures_.max_batch_wait_s = std::max(figures_.max_batch_wait_s, std::max(0.0, wait_s));
}

void HealthMeter::on_neighbour_age(double age_s) {
  age_s = std::max(0.0, age_s);
  ++ages_;
  age_sum_s_ += age_s;
  figures_.neighbour_age_mean_s = age_sum_s_ / static_cast<double>(ages_);
  figures_.neighbour_age_max_s = std::max(figures_.neighbour_age_max_s, age_s);
}

namespace {

std::string format(const char* pattern, double a, double b = 0.0, double c = 0.0) {
  char text[200];
  std::snprintf(text, sizeof text, pattern, a, b, c);
  return text;
}

}  // namespace

RunHealth assess_health(const RunHealthInput& input) {
  RunHealth health;
  auto degrade = [&health](std::string reason) {
    health.healthy = false;
    health.reasons.push_back(std::move(reason));
  };
  if (input.unscheduled_deaths > 0)
    degrade(format("%.0f agent process(es) died unscheduled", input.unscheduled_deaths));
  if (input.stalls > 0) degrade(format("%.0f agent stall(s): no estimate for too long", input.stalls));
  if (input.lockstep_timeouts > 0)
    degrade(format("%.0f agent(s) missed a lockstep deadline", input.lockstep_timeouts));
  if (input.non_finite_steps > 0) {
    degrade(format("non-finite (NaN/Inf) estimates at %.0f step(s): the results are not valid",
                   static_cast<double>(input.non_finite_steps)));
  }

  std::uint64_t ticks = 0, late = 0, missed = 0;
  double max_lateness_s = 0.0, age_max_s = 0.0;
  for (const auto& agent : input.agents) {
    ticks += agent.ticks;
    late += agent.late_ticks;
    missed += agent.missed_ticks;
    max_lateness_s = std::max(max_lateness_s, agent.max_tick_lateness_s);
    age_max_s = std::max(age_max_s, agent.neighbour_age_max_s);
  }
  const double late_fraction = ticks > 0 ? static_cast<double>(late) / static_cast<double>(ticks) : 0.0;
  const double world_rate_hz =
      input.world_steps_s > 0.0 ? static_cast<double>(input.world_steps) / input.world_steps_s : 0.0;
  const double late_step_fraction = input.world_steps > 0 ? static_cast<double>(input.late_world_steps) /
                                                                static_cast<double>(input.world_steps)
                                                          : 0.0;
  if (input.free_run) {
    if (late_fraction > kMaxLateTickFraction) {
      degrade(
          format("agents CPU-starved: %.1f %% of ticks late by more than half a period (limit %.0f %%); "
                 "max lateness %.3f s",
                 100.0 * late_fraction, 100.0 * kMaxLateTickFraction, max_lateness_s));
    }
    // One world period of slack: the last step is published a period before the loop ends.
    if (input.world_steps > 1 && world_rate_hz < kMinWorldRateFraction * input.rate_hz) {
      degrade(format("world rate %.2f Hz below run.rate_hz %.2f Hz", world_rate_hz, input.rate_hz));
    }
    if (late_step_fraction > kMaxLateWorldStepFraction) {
      degrade(
          format("orchestrator CPU-starved: %.1f %% of world steps late by more than half a period; "
                 "max lateness %.3f s",
                 100.0 * late_step_fraction, input.max_world_step_lateness_s));
    }
  }
  health.figures = {{"agents_reporting_health", input.agents.size()},
                    {"ticks", ticks},
                    {"late_ticks", late},
                    {"late_tick_fraction", late_fraction},
                    {"missed_ticks", missed},
                    {"max_tick_lateness_s", max_lateness_s},
                    {"max_neighbour_age_s", age_max_s},
                    {"world_steps", input.world_steps},
                    {"world_rate_hz", world_rate_hz},
                    {"late_world_steps", input.late_world_steps},
                    {"max_world_step_lateness_s", input.max_world_step_lateness_s},
                    {"unscheduled_deaths", input.unscheduled_deaths},
                    {"stalls", input.stalls},
                    {"lockstep_timeouts", input.lockstep_timeouts},
                    {"non_finite_steps", input.non_finite_steps}};
  return health;
}

nlohmann::json to_json(const RunHealth& health) {
  return {{"verdict", health.healthy ? "healthy" : "degraded"},
          {"reasons", health.reasons},
          {"figures", health.figures}};
}

}  // namespace swarmloc::runtime
