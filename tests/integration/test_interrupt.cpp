// SIGTERM to `swarmloc run` mid-run (issue 5, "nothing lost, nothing hangs"): the orchestrator exits
// within the deadline with exit code 1, leaves no agent process behind, and the run directory is complete
// with summary.json marked `interrupted: true`.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sched.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "process_helpers.hpp"

namespace interrupt_test {
namespace {

using swarmloc::testing::count_processes_matching;
using swarmloc::testing::fresh_directory;
using swarmloc::testing::read_json;
using swarmloc::testing::read_text;
using Clock = std::chrono::steady_clock;

const std::string kBinary = SWARMLOC_BINARY;
const std::string kScenario = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/ieif.yaml";

/// Starts `swarmloc run` with stdout and stderr to `log`; returns its pid.
pid_t start_run(const std::filesystem::path& dir, const std::filesystem::path& log) {
  // 8 agents for 600 steps at 10 Hz: a 60 s run, so the signal always lands mid-run.
  std::vector<std::string> args{kBinary,           "run",   kScenario,        "--out",
                                dir.string(),      "--set", "world.agents=8", "--set",
                                "world.anchors=3", "--set", "run.steps=600",  "--set",
                                "dds.domain_id=17"};
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      ::dup2(fd, STDOUT_FILENO);
      ::dup2(fd, STDERR_FILENO);
    }
    std::vector<char*> argv;
    for (auto& arg : args) argv.push_back(arg.data());
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  return pid;
}

/// Waits for `pid` until `deadline`; returns its wait status, or nullopt if it is still running.
std::optional<int> wait_until(pid_t pid, Clock::time_point deadline) {
  while (Clock::now() < deadline) {
    int status = 0;
    const pid_t done = ::waitpid(pid, &status, WNOHANG);
    if (done == pid) return status;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return std::nullopt;
}

/// SIGKILL, then reap: a run the test gives up on leaves no process behind.
void kill_and_reap(pid_t pid) {
  ::kill(pid, SIGKILL);
  ::waitpid(pid, nullptr, 0);
}

/// Mid-run: the first progress line with a step number (the orchestrator prints one when the agents
/// report, then every 5 s when stderr is not a terminal). False (and the run killed) after 60 s without.
bool wait_until_stepping(pid_t pid, const std::filesystem::path& log) {
  const auto give_up = Clock::now() + std::chrono::seconds(60);
  while (Clock::now() < give_up) {
    if (read_text(log).find(" step ") != std::string::npos) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  kill_and_reap(pid);
  return false;
}

/// A run in a fresh directory `name` (its output in `<name>.log` beside it), started and stepping.
struct SteppingRun {
  std::filesystem::path dir, log;
  pid_t pid = -1;  ///< -1: it did not start, or showed no step within 60 s (then killed)
};
SteppingRun start_stepping_run(const std::string& name) {
  SteppingRun run;
  run.dir = fresh_directory(name);
  run.log = run.dir.parent_path() / (run.dir.filename().string() + ".log");
  run.pid = start_run(run.dir, run.log);
  if (run.pid > 0 && !wait_until_stepping(run.pid, run.log)) run.pid = -1;
  return run;
}

/// Field `field` (1-based, as proc(5) numbers them) of /proc/<pid>/stat, or -1.
long proc_stat_field(pid_t pid, int field) {
  const std::string stat = read_text("/proc/" + std::to_string(pid) + "/stat");
  const auto comm_end = stat.rfind(')');
  if (comm_end == std::string::npos) return -1;
  std::istringstream rest(stat.substr(comm_end + 2));  // fields from 3 on
  std::string value;
  for (int i = 3; i <= field && rest >> value; ++i) {
    if (i == field) return std::stol(value);
  }
  return -1;
}

/// The processes whose parent is `parent`.
std::vector<pid_t> children_of(pid_t parent) {
  std::vector<pid_t> children;
  for (const auto& entry : std::filesystem::directory_iterator("/proc")) {
    const std::string name = entry.path().filename().string();
    if (name.empty() || !std::all_of(name.begin(), name.end(), ::isdigit)) continue;
    const pid_t pid = static_cast<pid_t>(std::stol(name));
    if (proc_stat_field(pid, 4) == parent) children.push_back(pid);
  }
  return children;
}

// docs/scale.md, "The world loop": in free run the orchestrator's world loop runs at real-time priority
// when the system grants it (root: CI), and the agents it launches run at the normal policy.
TEST(WorldPriority, TheWorldLoopIsRealTimeAndTheAgentsItLaunchesAreNot) {
  const auto [dir, log, pid] = start_stepping_run("priority");
  ASSERT_GT(pid, 0) << "no progress line within 60 s:\n" << read_text(log);
  constexpr int kPolicyField = 41;  // proc(5): the scheduling policy, SCHED_OTHER 0, SCHED_FIFO 1
  const long world_policy = proc_stat_field(pid, kPolicyField);
  std::vector<long> agent_policies;
  for (const pid_t child : children_of(pid)) agent_policies.push_back(proc_stat_field(child, kPolicyField));
  ::kill(pid, SIGTERM);
  if (!wait_until(pid, Clock::now() + std::chrono::seconds(10))) kill_and_reap(pid);
  EXPECT_EQ(world_policy, ::geteuid() == 0 ? SCHED_FIFO : SCHED_OTHER) << read_text(log);
  EXPECT_EQ(agent_policies.size(), 8U);
  for (const long policy : agent_policies) EXPECT_EQ(policy, SCHED_OTHER);
  std::filesystem::remove(log);
}

TEST(Interrupt, SigtermMidRunExitsPromptlyWithACompleteRunDirectoryAndNoAgentLeft) {
  const auto [dir, log, pid] = start_stepping_run("sigterm");
  ASSERT_GT(pid, 0) << "no progress line within 60 s:\n" << read_text(log);
  EXPECT_GT(count_processes_matching(dir.string()), 0) << "agents should be running before the signal";

  const auto signalled = Clock::now();
  ASSERT_EQ(::kill(pid, SIGTERM), 0);
  // The acceptance point is 5 s; the test allows 10 s so a loaded CI machine does not flake.
  const auto status = wait_until(pid, signalled + std::chrono::seconds(10));
  const double exit_s = std::chrono::duration<double>(Clock::now() - signalled).count();
  if (!status) {
    kill_and_reap(pid);
    FAIL() << "swarmloc run still running 10 s after SIGTERM:\n" << read_text(log);
  }
  std::printf("[ sigterm ] swarmloc run exited %.2f s after SIGTERM\n", exit_s);
  RecordProperty("exit_after_sigterm_s", std::to_string(exit_s));
  ASSERT_TRUE(WIFEXITED(*status)) << "killed by signal " << WTERMSIG(*status) << "\n" << read_text(log);
  EXPECT_EQ(WEXITSTATUS(*status), 1) << "interrupted runs exit 1\n" << read_text(log);

  // No agent process of this run is left (their command lines name the run directory).
  EXPECT_EQ(count_processes_matching(dir.string()), 0) << "agent processes outlived the orchestrator";

  // The run directory is complete and parseable.
  for (const char* file :
       {"scenario.yaml", "seed", "summary.json", "metrics.csv", "estimates.csv", "links.csv", "agents.csv"}) {
    EXPECT_TRUE(std::filesystem::exists(dir / file)) << file;
  }
  EXPECT_TRUE(std::filesystem::is_directory(dir / "logs"));
  nlohmann::json summary;
  ASSERT_NO_THROW(summary = read_json(dir / "summary.json")) << read_text(dir / "summary.json");
  EXPECT_EQ(summary["interrupted"], true);
  EXPECT_EQ(summary["agents"], 8);
  // Some steps were scored before the signal, not all 600.
  const auto metrics = read_text(dir / "metrics.csv");
  const auto lines = std::count(metrics.begin(), metrics.end(), '\n');
  EXPECT_GT(lines, 1) << metrics;
  EXPECT_LT(lines, 601) << "the run was not interrupted mid-run";
  std::filesystem::remove(log);
}

}  // namespace
}  // namespace interrupt_test
