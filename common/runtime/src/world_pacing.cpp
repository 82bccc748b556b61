#include "swarmloc/runtime/world_pacing.hpp"

#include <sched.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace swarmloc::runtime {

std::string raise_world_priority() {
  sched_param param{};
  param.sched_priority = 10;
  // pid 0: the calling thread only. Threads it creates later inherit the policy (SCHED_RESET_ON_FORK
  // would stop that for threads too, Cyclone's among them).
  if (sched_setscheduler(0, SCHED_FIFO, &param) == 0) return {};
  return std::strerror(errno);
}

void lower_to_normal_priority() {
  sched_param param{};
  sched_setscheduler(0, SCHED_OTHER, &param);
}

void StepProfile::close_step() {
  if (!open_) return;
  step_.wall_s += step_wall_s_;
  step_.cpu_s += step_cpu_s_;
  step_.max_wall_s = std::max(step_.max_wall_s, step_wall_s_);
  ++steps_;
  open_ = false;
}

void StepProfile::begin_step(double wall_s, double cpu_s, double lateness_s) {
  close_step();
  lateness_s = std::max(0.0, lateness_s);
  if (lateness_s > 0.5 * period_s_) ++late_steps_;
  max_lateness_s_ = std::max(max_lateness_s_, lateness_s);
  mark_wall_s_ = wall_s;
  mark_cpu_s_ = cpu_s;
  step_wall_s_ = step_cpu_s_ = 0.0;
  open_ = true;
}

void StepProfile::end_phase(Phase phase, double wall_s, double cpu_s) {
  if (!open_) return;
  auto& totals = phases_[static_cast<std::size_t>(phase)];
  const double wall = std::max(0.0, wall_s - mark_wall_s_);
  const double cpu = std::max(0.0, cpu_s - mark_cpu_s_);
  totals.wall_s += wall;
  totals.cpu_s += cpu;
  totals.max_wall_s = std::max(totals.max_wall_s, wall);
  step_wall_s_ += wall;
  step_cpu_s_ += cpu;
  mark_wall_s_ = wall_s;
  mark_cpu_s_ = cpu_s;
}

nlohmann::json StepProfile::to_json(double process_cpu_s) const {
  StepProfile closed = *this;
  closed.close_step();
  const double steps = static_cast<double>(std::max<std::int64_t>(1, closed.steps_));
  auto figures = [steps](const Totals& t) {
    return nlohmann::json{{"wall_ms_mean", 1e3 * t.wall_s / steps},
                          {"cpu_ms_mean", 1e3 * t.cpu_s / steps},
                          {"wall_ms_max", 1e3 * t.max_wall_s}};
  };
  static constexpr std::array<const char*, kPhases> kNames = {"generate", "publish", "take", "score"};
  nlohmann::json json = {{"steps", closed.steps_},
                         {"process_cpu_ms_per_step", 1e3 * process_cpu_s / steps},
                         {"step", figures(closed.step_)}};
  for (std::size_t i = 0; i < kPhases; ++i) json[kNames[i]] = figures(closed.phases_[i]);
  return json;
}

}  // namespace swarmloc::runtime
