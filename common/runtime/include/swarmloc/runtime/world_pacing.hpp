#pragma once
// The free-running world loop's priority, pacing and step profile (docs/scale.md, "The world loop"). The
// pacing and the profile take the clock readings from the caller, so both are tested without DDS or real
// time.
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

namespace swarmloc::runtime {

/// Runs the calling thread, and every thread it creates from now on, at a low real-time priority
/// (SCHED_FIFO 10), so that a machine saturated by agent processes cannot make the world late. Needs root
/// or CAP_SYS_NICE / RLIMIT_RTPRIO: returns an empty string when granted, else why not (the thread keeps
/// its policy). Processes forked meanwhile must call lower_to_normal_priority() before they exec.
std::string raise_world_priority();

/// The calling thread back to the normal policy (SCHED_OTHER); async-signal-safe, so a forked child may
/// call it before exec.
void lower_to_normal_priority();

/// Between two world steps: sleeps until `due` (in slices of at most `kTakeSliceS`, so that `stop` is seen)
/// and then takes every report that arrived meanwhile in one `take()`. A late loop takes them at once.
/// Once per step, not once per report: woken for each of hundreds of agents' reports, the world thread
/// (at real-time priority) preempted the agents thousands of times a second (docs/scale.md, "The world
/// loop"); and a late loop that skipped the take heard no agent and counted each of them as stalled.
inline constexpr double kTakeSliceS = 0.05;
template <typename Now, typename SleepFor, typename Take>
void take_when_due(std::chrono::steady_clock::time_point due, Now&& now, SleepFor&& sleep_for, Take&& take,
                   const std::atomic<bool>& stop) {
  for (auto left = due - now(); left.count() > 0 && !stop.load(); left = due - now())
    sleep_for(std::min(std::chrono::duration<double>(left).count(), kTakeSliceS));
  take();
}

/// The same on the steady clock and the real sleep.
template <typename Take>
void take_when_due(std::chrono::steady_clock::time_point due, Take&& take, const std::atomic<bool>& stop) {
  take_when_due(
      due, [] { return std::chrono::steady_clock::now(); },
      [](double s) { std::this_thread::sleep_for(std::chrono::duration<double>(s)); }, take, stop);
}

/// Where each world step's time goes, by phase: wall time and the world thread's CPU time; and how late
/// the steps started against their schedule.
class StepProfile {
 public:
  enum class Phase : std::uint8_t { kGenerate, kPublish, kTake, kScore };
  static constexpr std::size_t kPhases = 4;

  explicit StepProfile(double period_s) : period_s_(period_s) {}
  /// A step starts, `lateness_s` after its time (0 without a schedule, as in lockstep): the phases that
  /// follow are measured from here. A step more than half a period late counts as late.
  void begin_step(double wall_s, double cpu_s, double lateness_s);
  /// The phase that ran since the last mark ends now.
  void end_phase(Phase phase, double wall_s, double cpu_s);
  /// summary.json's `orchestrator`: per phase and per whole step, mean wall and CPU milliseconds per step
  /// and the longest wall time; with the CPU the whole process (every thread) used over those steps.
  [[nodiscard]] nlohmann::json to_json(double process_cpu_s) const;
  [[nodiscard]] std::int64_t steps() const { return steps_; }
  [[nodiscard]] std::int64_t late_steps() const { return late_steps_; }
  [[nodiscard]] double max_lateness_s() const { return max_lateness_s_; }

 private:
  struct Totals {
    double wall_s = 0.0, cpu_s = 0.0, max_wall_s = 0.0;
  };
  std::array<Totals, kPhases> phases_{};
  Totals step_{};
  double mark_wall_s_ = 0.0, mark_cpu_s_ = 0.0;
  double step_wall_s_ = 0.0, step_cpu_s_ = 0.0;  ///< this step so far
  double period_s_;
  double max_lateness_s_ = 0.0;
  std::int64_t steps_ = 0;
  std::int64_t late_steps_ = 0;
  bool open_ = false;

  void close_step();
};

}  // namespace swarmloc::runtime
