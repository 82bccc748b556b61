#pragma once
// What the orchestrator's commands share on the console: the interrupt flag set by SIGINT, SIGTERM and
// SIGHUP, and the one progress line.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>

#include "swarmloc/world/metrics.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::orchestrator {

using Clock = std::chrono::steady_clock;

/// Set by SIGINT, SIGTERM and SIGHUP once install_interrupt_handlers() ran; never cleared.
std::atomic<bool>& interrupted();
/// Set by a second such signal: it cancels the saving of a run the first one stopped.
std::atomic<bool>& interrupted_again();
/// SIGINT, SIGTERM and SIGHUP (terminal or ssh closed) set interrupted(); SIGPIPE is ignored, so a
/// closed stdout (`swarmloc run … | head -1`) fails writes instead of killing the run.
void install_interrupt_handlers();

inline double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

/// "for 10 s" / "until Ctrl-C" (--view-hold).
std::string hold_text(double seconds);

/// Makes spdlog's default logger write above the open progress line on a terminal, not onto its end.
void log_above_progress_line();

/// One progress line on stderr, rewritten in place on a terminal (log lines go above it).
class Progress {
 public:
  /// On a terminal when stderr is one.
  explicit Progress(bool enabled);
  Progress(bool enabled, bool terminal);
  void update(const std::string& line, bool force = false);
  void finish();

 private:
  bool enabled_;
  bool tty_;
  Clock::time_point last_ = Clock::now() - std::chrono::hours(1);
};

/// "[0s] starting dml: 30 agents, 300 steps at 10 Hz": a run's first progress line.
std::string starting_line(const config::Scenario& scenario);

std::string progress_line(std::int64_t step, int steps, const world::ErrorStats& errors, int reporting,
                          int agents, double elapsed_s);

/// Long computations (world building, simulation, writing) cancelled by interrupted() and reporting on
/// `progress` ("[  3.1s] world: neighbour graph: 40 %"). `progress` must outlive the result.
world::WorkControl interruptible_work(Progress& progress, Clock::time_point started);

/// A run that ends before anything was written leaves no empty directory behind (unless it was there).
void discard_if_empty(const std::filesystem::path& run_dir, bool existed);

}  // namespace swarmloc::orchestrator
