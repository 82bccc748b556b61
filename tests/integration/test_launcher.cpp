// The local launcher's child environment: agents run with one OpenBLAS thread unless the user chose
// otherwise (the pthreads OpenBLAS the binary links spins ~0.1 s of CPU per process start otherwise),
// and at the requested nice increment.
#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>
#include <thread>

#include "launcher.hpp"
#include "process_helpers.hpp"

namespace {

using swarmloc::orchestrator::ProcessLauncher;

/// Runs `sh -c script` through the launcher at `nice_increment` and returns what it printed.
std::string child_output(const std::string& name, const std::string& script, int nice_increment = 0) {
  const auto output = swarmloc::testing::fresh_directory(name) / "child.out";
  ProcessLauncher launcher;
  const int child = launcher.launch({"/bin/sh", "-c", script}, output, nice_increment);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (launcher.poll() > 0 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(launcher.exit_code(child), std::optional<int>(0));
  std::ifstream in(output);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string child_blas_threads(const std::string& name) {
  return child_output(name, "printf %s \"${OPENBLAS_NUM_THREADS-unset}\"");
}

TEST(Launcher, ChildrenGetOneOpenBlasThreadUnlessTheUserSetIt) {
  const char* saved = std::getenv("OPENBLAS_NUM_THREADS");
  const std::optional<std::string> previous = saved ? std::optional<std::string>(saved) : std::nullopt;

  unsetenv("OPENBLAS_NUM_THREADS");
  EXPECT_EQ(child_blas_threads("launcher-blas-default"), "1");
  setenv("OPENBLAS_NUM_THREADS", "3", 1);
  EXPECT_EQ(child_blas_threads("launcher-blas-user"), "3");

  if (previous)
    setenv("OPENBLAS_NUM_THREADS", previous->c_str(), 1);
  else
    unsetenv("OPENBLAS_NUM_THREADS");
}

/// The nice value a child launched with `increment` reports (coreutils `nice` prints it).
int child_nice(const std::string& name, int increment) {
  return std::stoi(child_output(name, "nice", increment));
}

// run.agent_nice: agents run nicer than the orchestrator, so on a saturated machine the world keeps
// its rate (docs/scale.md).
TEST(Launcher, ChildrenRunNicerByTheRequestedIncrementCappedAtNineteen) {
  const int ours = getpriority(PRIO_PROCESS, 0);
  EXPECT_EQ(child_nice("launcher-nice-0", 0), ours);
  EXPECT_EQ(child_nice("launcher-nice-7", 7), std::min(19, ours + 7));
  EXPECT_EQ(child_nice("launcher-nice-19", 19), 19);
}

}  // namespace
