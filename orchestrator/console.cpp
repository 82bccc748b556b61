#include "console.hpp"

#include <spdlog/sinks/base_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cmath>
#include <csignal>
#include <cstdio>
#include <memory>
#include <mutex>

namespace swarmloc::orchestrator {
namespace {

std::atomic<bool> g_interrupted{false};
std::atomic<bool> g_interrupted_again{false};
// Flags only; never DDS from a handler.
void on_signal(int /*signal*/) {
  if (g_interrupted.exchange(true)) g_interrupted_again.store(true);
}

/// The progress line as it stands on the terminal (empty: none is open), shared by Progress and the log.
struct OpenLine {
  std::mutex mutex;
  std::string text;
};
OpenLine& open_line() {
  static OpenLine line;
  return line;
}

/// stderr's log sink with the progress line kept below the log: it clears the open line, writes the log
/// line (coloured as the default sink colours it), then draws the progress line again.
class AboveProgressSink final : public spdlog::sinks::base_sink<std::mutex> {
 protected:
  void sink_it_(const spdlog::details::log_msg& message) override {
    auto& line = open_line();
    const std::lock_guard lock(line.mutex);
    if (!line.text.empty()) std::fputs("\r\x1b[K", stderr);
    stderr_->log(message);
    if (!line.text.empty()) std::fputs(line.text.c_str(), stderr);
    std::fflush(stderr);
  }
  void flush_() override { stderr_->flush(); }
  void set_pattern_(const std::string& pattern) override { stderr_->set_pattern(pattern); }
  void set_formatter_(std::unique_ptr<spdlog::formatter> formatter) override {
    stderr_->set_formatter(std::move(formatter));
  }

 private:
  std::shared_ptr<spdlog::sinks::sink> stderr_ = std::make_shared<spdlog::sinks::stderr_color_sink_st>();
};

}  // namespace

void log_above_progress_line() {
  spdlog::set_default_logger(std::make_shared<spdlog::logger>("", std::make_shared<AboveProgressSink>()));
}

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

Progress::Progress(bool enabled) : Progress(enabled, isatty(STDERR_FILENO) != 0) {}

Progress::Progress(bool enabled, bool terminal) : enabled_(enabled), tty_(terminal) {}

void Progress::update(const std::string& line, bool force) {
  if (!enabled_) return;
  const auto now = Clock::now();
  if (!force && now - last_ < std::chrono::milliseconds(tty_ ? 250 : 5000)) return;
  last_ = now;
  if (!tty_) {
    std::fprintf(stderr, "%s\n", line.c_str());
    std::fflush(stderr);
    return;
  }
  // Rewritten in place: back to the line's start, the new text, the rest of the old one erased.
  auto& open = open_line();
  const std::lock_guard lock(open.mutex);
  std::fprintf(stderr, "\r%s\x1b[K", line.c_str());
  std::fflush(stderr);
  open.text = line;
}

void Progress::finish() {
  if (!enabled_ || !tty_) return;
  auto& open = open_line();
  const std::lock_guard lock(open.mutex);
  std::fprintf(stderr, "\n");
  open.text.clear();
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
