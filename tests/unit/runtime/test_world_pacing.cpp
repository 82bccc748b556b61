// The free-running world loop's pacing, step profile and priority (swarmloc/runtime/world_pacing.hpp).
#include <gtest/gtest.h>
#include <sched.h>
#include <sys/wait.h>
#include <unistd.h>

#include <thread>
#include <vector>

#include "swarmloc/runtime/world_pacing.hpp"

namespace swarmloc::runtime {
namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

TEST(WorldPacing, ALateLoopTakesTheReportsAtOnce) {
  const Clock::time_point due = Clock::time_point{} + 1s;
  const Clock::time_point late = due + 300ms;
  int takes = 0;
  std::vector<double> sleeps;
  const std::atomic<bool> stop{false};
  take_when_due(
      due, [&] { return late; }, [&](double s) { sleeps.push_back(s); }, [&] { ++takes; }, stop);
  EXPECT_EQ(takes, 1);
  EXPECT_TRUE(sleeps.empty());
}

TEST(WorldPacing, AnEarlyLoopSleepsInSlicesUntilTheStepIsDueAndThenTakesOnce) {
  const Clock::time_point due = Clock::time_point{} + 1s;
  Clock::time_point now = due - 120ms;
  int takes = 0;
  std::vector<double> sleeps;
  const std::atomic<bool> stop{false};
  take_when_due(
      due, [&] { return now; },
      [&](double s) {
        EXPECT_EQ(takes, 0);  // no take before the step is due
        sleeps.push_back(s);
        now += std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
      },
      [&] { ++takes; }, stop);
  EXPECT_EQ(takes, 1);
  ASSERT_EQ(sleeps.size(), 3U);
  EXPECT_NEAR(sleeps[0], kTakeSliceS, 1e-9);
  EXPECT_NEAR(sleeps[1], kTakeSliceS, 1e-9);
  EXPECT_NEAR(sleeps[2], 0.12 - 2 * kTakeSliceS, 1e-9);
  EXPECT_GE(now, due);
}

TEST(WorldPacing, AStopEndsTheSleepAndStillTakes) {
  const Clock::time_point due = Clock::time_point{} + 1s;
  Clock::time_point now = due - 1s;
  int takes = 0, sleeps = 0;
  std::atomic<bool> stop{false};
  take_when_due(
      due, [&] { return now; },
      [&](double s) {
        ++sleeps;
        now += std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
        stop = true;  // Ctrl-C during the first slice
      },
      [&] { ++takes; }, stop);
  EXPECT_EQ(sleeps, 1);
  EXPECT_EQ(takes, 1);
}

TEST(WorldPacing, TheProfileSumsEachPhaseAndCountsTheLateSteps) {
  StepProfile profile(0.1);
  // Step 1 on time: generate 2 ms (1 ms CPU), publish 3 ms (3 ms CPU), take 90 ms (0.5 ms), score 5 ms (2
  // ms).
  profile.begin_step(10.000, 1.0, 0.01);
  profile.end_phase(StepProfile::Phase::kGenerate, 10.002, 1.001);
  profile.end_phase(StepProfile::Phase::kPublish, 10.005, 1.004);
  profile.end_phase(StepProfile::Phase::kTake, 10.095, 1.0045);
  profile.end_phase(StepProfile::Phase::kScore, 10.100, 1.0065);
  // Step 2 is 0.06 s late (more than half the period) and its publish waits 40 ms for the CPU.
  profile.begin_step(10.160, 1.0065, 0.06);
  profile.end_phase(StepProfile::Phase::kGenerate, 10.162, 1.0075);
  profile.end_phase(StepProfile::Phase::kPublish, 10.205, 1.0105);
  profile.end_phase(StepProfile::Phase::kTake, 10.205, 1.0105);
  profile.end_phase(StepProfile::Phase::kScore, 10.210, 1.0125);
  const auto json = profile.to_json(0.03);
  EXPECT_EQ(json["steps"], 2);
  EXPECT_EQ(profile.late_steps(), 1);
  EXPECT_DOUBLE_EQ(profile.max_lateness_s(), 0.06);
  EXPECT_NEAR(json["generate"]["wall_ms_mean"].get<double>(), 2.0, 1e-6);
  EXPECT_NEAR(json["generate"]["cpu_ms_mean"].get<double>(), 1.0, 1e-6);
  EXPECT_NEAR(json["publish"]["wall_ms_mean"].get<double>(), 23.0, 1e-6);
  EXPECT_NEAR(json["publish"]["wall_ms_max"].get<double>(), 43.0, 1e-6);
  EXPECT_NEAR(json["publish"]["cpu_ms_mean"].get<double>(), 3.0, 1e-6);
  EXPECT_NEAR(json["take"]["wall_ms_mean"].get<double>(), 45.0, 1e-6);
  EXPECT_NEAR(json["step"]["wall_ms_mean"].get<double>(), 75.0, 1e-6);
  EXPECT_NEAR(json["step"]["wall_ms_max"].get<double>(), 100.0, 1e-6);
  EXPECT_NEAR(json["step"]["cpu_ms_mean"].get<double>(), 6.25, 1e-6);
  EXPECT_NEAR(json["process_cpu_ms_per_step"].get<double>(), 15.0, 1e-6);
}

int policy_of_this_thread() { return sched_getscheduler(0) & ~SCHED_RESET_ON_FORK; }

TEST(WorldPacing, TheRaisedWorldThreadsThreadsAreRealTimeAndAForkedChildLowersItselfToNormal) {
  // In a thread of its own: the test runner's thread keeps its policy.
  std::string refused;
  int raised = -1, inherited = -1, child = -1, lowered = -1;
  std::thread world([&] {
    refused = raise_world_priority();
    if (!refused.empty()) return;
    raised = policy_of_this_thread();
    std::thread created([&] { inherited = policy_of_this_thread(); });
    created.join();
    const pid_t pid = fork();
    if (pid == 0) {
      lower_to_normal_priority();  // what the launcher's child does before exec
      _exit(policy_of_this_thread() == SCHED_OTHER ? 0 : 1);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    child = WIFEXITED(status) && WEXITSTATUS(status) == 0 ? SCHED_OTHER : -2;
    lower_to_normal_priority();
    lowered = policy_of_this_thread();
  });
  world.join();
  // scripts/test runs as root (CI), where real time is granted; elsewhere the refusal says why.
  if (geteuid() != 0 && !refused.empty()) return;
  ASSERT_EQ(refused, "");
  EXPECT_EQ(raised, SCHED_FIFO);
  EXPECT_EQ(inherited, SCHED_FIFO);
  EXPECT_EQ(child, SCHED_OTHER);
  EXPECT_EQ(lowered, SCHED_OTHER);
}

}  // namespace
}  // namespace swarmloc::runtime
