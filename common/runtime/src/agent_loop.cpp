#include "swarmloc/runtime/agent_loop.hpp"

#include <algorithm>
#include <cmath>

#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/runtime/agent_factory.hpp"
#include "swarmloc/runtime/hostile.hpp"

namespace swarmloc::runtime {
namespace {

/// Hellos of a sensor-only agent: often enough that the orchestrator counts it within a second.
constexpr double kHelloPeriodS = 0.5;
/// A gap this long between two calls means the process did not run (SIGSTOP, a starved machine).
constexpr double kOwnPauseS = 1.0;

}  // namespace

LoopSettings loop_settings(const config::Scenario& scenario, const AgentManifest& manifest, bool hostile) {
  LoopSettings settings;
  settings.id = manifest.id;
  settings.clock = manifest.clock;
  settings.world_period_s = 1.0 / scenario.run.rate_hz;
  settings.steps_per_world_step = scenario.run.agent_steps_per_world_step;
  settings.phase_fraction = tick_phase_fraction(scenario, manifest.id);
  settings.sensor_only = config::runs_in_fusion_centre(scenario.algorithm.name);
  settings.lockstep = scenario.run.mode == config::RunMode::kLockstep && !settings.sensor_only;
  settings.hostile = hostile;
  settings.startup_timeout_s = scenario.run.startup_timeout_s;
  settings.results_hash = config::results_hash(scenario);
  return settings;
}

AgentLoop::AgentLoop(AgentRuntime runtime, const LoopSettings& settings, AgentPort& port)
    : runtime_(std::move(runtime)),
      settings_(settings),
      port_(port),
      health_(settings.world_period_s / settings.steps_per_world_step),
      last_heard_s_(runtime_.neighbours().size(), std::numeric_limits<double>::quiet_NaN()) {}

double AgentLoop::tick_period_s() const {
  // The timer runs on the agent's own clock: a local period lasts period/(1 + drift) of monotonic time.
  return settings_.clock.mono_duration(settings_.world_period_s / settings_.steps_per_world_step);
}

double AgentLoop::tick_time_s(std::int64_t index) const {
  // From the index, not accumulated: a drift-free aligned clock ticks exactly at m·T.
  return timer_start_s_ + (settings_.phase_fraction + static_cast<double>(index)) * tick_period_s();
}

std::int64_t AgentLoop::local_stamp_ns(double now_s) const {
  return static_cast<std::int64_t>(std::llround(settings_.clock.local_time(now_s) * 1e9));
}

void AgentLoop::announce(double now_s) { port_.publish(runtime_.initial_publication(local_stamp_ns(now_s))); }

void AgentLoop::start(double now_s) {
  started_ = true;
  timer_start_s_ = now_s;
  next_tick_ = 1;
  last_batch_s_ = now_s;  // the silence timer starts at START, not at launch
  last_call_s_ = now_s;
  next_hello_s_ = now_s;
}

void AgentLoop::on_batch(const Header& header, estimators::MeasurementBatch batch, double now_s) {
  if (started_) note_time(now_s);
  runtime_.on_batch(header, std::move(batch));
  health_.on_batch(batch_waiting_since_s_.has_value());
  if (!batch_waiting_since_s_) batch_waiting_since_s_ = now_s;
  last_batch_s_ = now_s;
}

void AgentLoop::on_sample(const InboundSample& sample, double now_s) {
  const auto& neighbours = runtime_.neighbours();
  if (const auto slot = std::lower_bound(neighbours.begin(), neighbours.end(), sample.header.agent_id);
      slot != neighbours.end() && *slot == sample.header.agent_id) {
    last_heard_s_[static_cast<std::size_t>(slot - neighbours.begin())] = now_s;
  }
  if (settings_.lockstep) {
    held_.push_back(sample);
    return;
  }
  std::visit([&](const auto& message) { runtime_.on_sample(sample.header, message, sample.well_formed); },
             sample.message);
}

void AgentLoop::note_time(double now_s) {
  const double gap_s = now_s - last_call_s_;
  if (gap_s > kOwnPauseS) last_batch_s_ = std::min(last_batch_s_ + gap_s, now_s);
  last_call_s_ = now_s;
}

int AgentLoop::advance(double now_s) {
  if (!started_) return 0;
  note_time(now_s);
  if (settings_.sensor_only) {
    // The fusion centre estimates and reports every agent; hellos (steps_run = 0) never replace those.
    if (now_s >= next_hello_s_) {
      next_hello_s_ = now_s + kHelloPeriodS;
      port_.report(report(now_s, cpu_s_));
    }
    return 0;
  }
  if (settings_.lockstep) return step_lockstep(now_s);
  if (now_s < tick_time_s(next_tick_)) return 0;
  return tick(now_s);
}

double AgentLoop::next_due_s() const {
  if (!started_ || settings_.lockstep) return std::numeric_limits<double>::infinity();
  if (settings_.sensor_only) return next_hello_s_;
  return tick_time_s(next_tick_);
}

int AgentLoop::tick(double now_s) {
  const double lateness_s = now_s - tick_time_s(next_tick_);
  ++next_tick_;
  std::uint32_t missed = 0;
  while (tick_time_s(next_tick_) <= now_s) {  // overran: skip what was missed, do not burst
    ++next_tick_;
    ++missed;
  }
  if (paused_) return 0;  // SIGSTOP in the simulator: the period passes without a step
  health_.on_tick(lateness_s, missed);
  step(now_s);
  return 1;
}

int AgentLoop::step_lockstep(double now_s) {
  // One step per world-step batch, on the neighbours' samples of earlier steps only.
  if (!runtime_.has_pending_batch() || paused_) return 0;
  release_held(runtime_.steps_run());
  health_.on_tick(0.0, 0);  // lockstep steps on data, not on a schedule: nothing to be late for
  step(now_s);
  return 1;
}

void AgentLoop::release_held(std::int64_t step) {
  // In arrival order, as the simulator's bus delivers them; later steps' samples stay.
  std::vector<InboundSample> later;
  for (const auto& sample : held_) {
    if (sample.header.step < step) {
      std::visit([&](const auto& message) { runtime_.on_sample(sample.header, message, sample.well_formed); },
                 sample.message);
    } else {
      later.push_back(sample);
    }
  }
  held_ = std::move(later);
}

void AgentLoop::note_step(double now_s) {
  if (batch_waiting_since_s_) {
    health_.on_batch_used(now_s - *batch_waiting_since_s_);
    batch_waiting_since_s_.reset();
  }
  for (const double heard_s : last_heard_s_) {
    if (!std::isnan(heard_s)) health_.on_neighbour_age(now_s - heard_s);
  }
}

void AgentLoop::step(double now_s) {
  note_step(now_s);
  auto publication = runtime_.step(local_stamp_ns(now_s));
  if (settings_.hostile) make_hostile(publication.outbox, publication.header.step);
  port_.publish(publication);
  if (settings_.lockstep) port_.flush();
  // One report per world period is what the orchestrator scores; more would only load it.
  if (!settings_.reports || ++ticks_since_report_ < settings_.steps_per_world_step) return;
  ticks_since_report_ = 0;
  port_.report(report(now_s, cpu_s_));
}

bool AgentLoop::orchestrator_silent(double now_s) {
  if (!started_) return false;
  note_time(now_s);
  // Lockstep waits for the slowest agent every step: allow it the start-up timeout.
  const double limit_s =
      settings_.lockstep ? settings_.startup_timeout_s : std::max(5.0, 50.0 * settings_.world_period_s);
  return now_s - last_batch_s_ > limit_s;
}

EstimateReport AgentLoop::report(double now_s, double cpu_s) const {
  EstimateReport r = runtime_.report(local_stamp_ns(now_s), cpu_s);
  r.results_hash = settings_.results_hash;
  r.health = health_.figures();
  return r;
}

}  // namespace swarmloc::runtime
