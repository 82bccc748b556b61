// The orchestrator's console on a terminal (orchestrator/console.hpp): the progress line is rewritten in
// place, and a log line written while it is open goes above it instead of onto its end.
#include <gtest/gtest.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "console.hpp"
#include "process_helpers.hpp"

namespace swarmloc::orchestrator::console_test {
namespace {

/// Everything written to stderr while `body` runs.
template <typename Body>
std::string captured_stderr(Body body) {
  const auto path = testing::fresh_directory("console") / "stderr.txt";
  std::fflush(stderr);
  const int saved = dup(STDERR_FILENO);
  if (std::freopen(path.c_str(), "w", stderr) == nullptr) return "cannot redirect stderr";
  body();
  std::fflush(stderr);
  dup2(saved, STDERR_FILENO);
  close(saved);
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(Console, ALogLineGoesAboveTheOpenProgressLineWhichIsDrawnAgainBelowIt) {
  const auto text = captured_stderr([] {
    log_above_progress_line();
    spdlog::set_pattern("%v");
    Progress progress(true, /*terminal=*/true);
    progress.update("[0s] starting", true);
    spdlog::info("run id r1");
    progress.update("[1s] step 1", true);
    progress.finish();
  });
  spdlog::set_pattern("%H:%M:%S.%e %^%l%$ %v");
  // The line is cleared before the log line, the log line ends its own line, the progress line comes back.
  EXPECT_EQ(text, "\r[0s] starting\x1b[K\r\x1b[Krun id r1\n[0s] starting\r[1s] step 1\x1b[K\n");
  EXPECT_EQ(text.find("starting\x1b[Krun id"), std::string::npos) << text;
}

TEST(Console, OffATerminalEveryProgressLineIsItsOwnLineAndLogLinesAreUntouched) {
  const auto text = captured_stderr([] {
    log_above_progress_line();
    spdlog::set_pattern("%v");
    Progress progress(true, /*terminal=*/false);
    progress.update("[0s] starting", true);
    spdlog::info("run id r1");
    progress.finish();
  });
  spdlog::set_pattern("%H:%M:%S.%e %^%l%$ %v");
  EXPECT_EQ(text, "[0s] starting\nrun id r1\n");
}

}  // namespace
}  // namespace swarmloc::orchestrator::console_test
