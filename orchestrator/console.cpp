#include "console.hpp"

#include <unistd.h>

#include <cmath>
#include <csignal>
#include <cstdio>

namespace swarmloc::orchestrator {
namespace {

std::atomic<bool> g_interrupted{false};
std::atomic<bool> g_interrupted_again{false};
// Flags only; never DDS from a handler.
void on_signal(int /*signal*/) {
  if (g_interrupted.exchange(true)) g_interrupted_again.store(true);
}

}  // namespace

std::atomic<bool>& interrupted() { return g_interrupted; }
std::atomic<bool>& interrupted_again() { return g_interrupted_again; }

void install_interrupt_handlers() {
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::signal(SIGHUP, on_signal);
  std::signal(SIGPIPE, SIG_IGN);
}

std::string hold_text(double seconds) {
  if (!std::isfinite(seconds)) return "until Ctrl-C";
  char text[64];
  std::snprintf(text, sizeof text, "for %g s", seconds);
  return text;
}

Progress::Progress(bool enabled) : enabled_(enabled), tty_(isatty(STDERR_FILENO) != 0) {}

void Progress::update(const std::string& line, bool force) {
  if (!enabled_) return;
  const auto now = Clock::now();
  if (!force && now - last_ < std::chrono::milliseconds(tty_ ? 250 : 5000)) return;
  last_ = now;
  std::fprintf(stderr, tty_ ? "\r%-100s" : "%s\n", line.c_str());
  std::fflush(stderr);
}

void Progress::finish() {
  if (enabled_ && tty_) std::fprintf(stderr, "\n");
}

std::string starting_line(const config::Scenario& scenario) {
  char line[160];
  std::snprintf(line, sizeof line, "[0s] starting %s: %d agents, %d steps at %g Hz",
                scenario.algorithm.name.c_str(), scenario.world.agents, scenario.run.steps,
                scenario.run.rate_hz);
  return line;
}

std::string progress_line(std::int64_t step, int steps, const world::ErrorStats& errors, int reporting,
                          int agents, double elapsed_s) {
  char line[200];
  std::snprintf(line, sizeof line,
                "[%5.1fs] step %4lld/%d  rmse %8.4f m  max %8.4f m  agents reporting %d/%d", elapsed_s,
                static_cast<long long>(step) + 1, steps, errors.rmse_m, errors.max_error_m, reporting,
                agents);
  return line;
}

world::WorkControl interruptible_work(Progress& progress, Clock::time_point started) {
  world::WorkControl control;
  control.cancel = &interrupted();
  control.on_progress = [&progress, started](const std::string& phase, double fraction) {
    char line[240];
    std::snprintf(line, sizeof line, "[%5.1fs] %s: %.0f %%", seconds_since(started), phase.c_str(),
                  100.0 * fraction);
    progress.update(line);
  };
  return control;
}

void discard_if_empty(const std::filesystem::path& run_dir, bool existed) {
  std::error_code ignored;
  if (!run_dir.empty() && !existed && std::filesystem::is_empty(run_dir, ignored))
    std::filesystem::remove(run_dir, ignored);
}

}  // namespace swarmloc::orchestrator
