// The local launcher: children run at the requested nice increment; the agent executable it starts is
// lean (no SDPA/MUMPS/BLAS: the pthreads OpenBLAS spun ~0.1 s of CPU per process start when agents linked
// it) and refuses a bad manifest with exit code 2.
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

namespace launcher_test {
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

/// The shared objects `binary` loads, as ldd lists them.
std::string shared_objects(const std::string& binary) {
  const auto result = swarmloc::testing::run_command("ldd " + binary);
  EXPECT_EQ(result.exit_code, 0) << result.output;
  return result.output;
}

TEST(AgentBinary, LinksNoSdpaMumpsBlasLapackOrFortran) {
  const std::string libraries = shared_objects(SWARMLOC_AGENT_BINARY);
  ASSERT_NE(libraries.find("libddsc"), std::string::npos) << libraries;  // it is the DDS agent
  for (const char* heavy : {"sdpa", "mumps", "blas", "lapack", "gfortran"})
    EXPECT_EQ(libraries.find(heavy), std::string::npos)
        << SWARMLOC_AGENT_BINARY << " links " << heavy << ":\n"
        << libraries;
}

TEST(AgentBinary, RefusesABadManifestWithExitCodeTwoAndSaysWhy) {
  const auto dir = swarmloc::testing::fresh_directory("agent-bad-manifest");
  std::ofstream(dir / "manifest.json") << R"({"format": "swarmloc-agent-manifest", "version": 1, "id": 9})";
  const std::string scenario = SWARMLOC_SOURCE_DIR "/scenarios/ieif.yaml";
  const auto result =
      swarmloc::testing::run_command(std::string(SWARMLOC_AGENT_BINARY) + " --scenario " + scenario +
                                     " --manifest " + (dir / "manifest.json").string());
  EXPECT_EQ(result.exit_code, 2) << result.output;
  EXPECT_NE(result.output.find("invalid agent manifest"), std::string::npos) << result.output;
  const auto missing =
      swarmloc::testing::run_command(std::string(SWARMLOC_AGENT_BINARY) + " --scenario " + scenario);
  EXPECT_EQ(missing.exit_code, 2) << missing.output;  // --manifest is required
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
}  // namespace launcher_test
