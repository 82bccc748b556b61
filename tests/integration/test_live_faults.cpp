// The live path's fault handling (docs/robustness.md, "Live sensor input"): the player makes one robot's
// drivers send a message twice, two out of order, stop for 5 s and jump the robot's clock by +10 s. The
// agent counts each once, nothing crashes, and its estimate recovers. Domain 72 (no other test uses it).
#include <gtest/gtest.h>

#include "live_helpers.hpp"

namespace live_faults_test {
namespace {

using swarmloc::testing::kLiveRateHz;
using swarmloc::testing::kLiveSteps;
using swarmloc::testing::live_rmse;
using swarmloc::testing::LiveRun;
using swarmloc::testing::LiveWorld;
using swarmloc::testing::make_live_world;
using swarmloc::testing::run_live;

constexpr int kFaultDomain = 72;

struct LiveFaultData {
  LiveWorld world;
  LiveRun run;
  std::string faulty;
};

const LiveFaultData& live_fault_data() {
  static const LiveFaultData data = [] {
    LiveFaultData d;
    d.world = make_live_world("live-faults", kFaultDomain);
    int fault = 0;
    while (d.world.anchor[static_cast<std::size_t>(fault)]) ++fault;  // a robot, not an anchor
    d.faulty = d.world.names[static_cast<std::size_t>(fault)];
    d.run = run_live(d.world, kFaultDomain, fault);
    return d;
  }();
  return data;
}

void expect_nothing_crashed(const LiveFaultData& data) {
  const std::string& out = data.run.script.output;
  EXPECT_NE(out.find("player=0"), std::string::npos) << out;
  EXPECT_EQ(out.find("agent=1"), std::string::npos) << out;
  EXPECT_EQ(out.find("agent=2"), std::string::npos) << out;
  EXPECT_EQ(data.run.stats.size(), data.world.names.size()) << out;
}

void expect_each_fault_counted_once(const LiveFaultData& data) {
  ASSERT_TRUE(data.run.stats.count(data.faulty));
  const auto& stats = data.run.stats.at(data.faulty);
  for (const char* stream : {"ranges", "odom"}) {
    EXPECT_EQ(stats[stream]["duplicates"], 1) << stream << " " << stats.dump(2);
    EXPECT_EQ(stats[stream]["reordered"], 1) << stream << " " << stats.dump(2);
    EXPECT_EQ(stats[stream]["silences"], 1) << stream << " " << stats.dump(2);
    EXPECT_EQ(stats[stream]["clock_jumps"], 1) << stream << " " << stats.dump(2);
  }
  // Every step the driver sent, less the 5 s it was silent and step 60, which came after 61.
  EXPECT_EQ(stats["ranges"]["accepted"], kLiveSteps - static_cast<int>(5 * kLiveRateHz) - 1) << stats.dump(2);
  for (const auto& [name, other] : data.run.stats) {
    if (name == data.faulty) continue;
    EXPECT_EQ(other["ranges"]["duplicates"], 0) << name;
    EXPECT_EQ(other["ranges"]["clock_jumps"], 0) << name;
  }
}

void expect_estimate_recovered(const LiveFaultData& data) {
  std::size_t index = 0;
  while (data.world.names[index] != data.faulty) ++index;
  ASSERT_TRUE(data.run.last_pose.count(data.faulty));
  const double error = (data.run.last_pose.at(data.faulty) - data.world.final_truth[index]).norm();
  std::printf("%s: final error %.4f m after the faults\n", data.faulty.c_str(), error);
  EXPECT_LT(error, 0.05);
  EXPECT_LT(live_rmse(data.world, data.run), 0.05);
}

// One live run (about 30 s) for all three checks.
TEST(LiveFaults, EachFaultIsCountedOnceNothingCrashesAndTheEstimateRecovers) {
  const auto& data = live_fault_data();
  expect_nothing_crashed(data);
  expect_each_fault_counted_once(data);
  expect_estimate_recovered(data);
}

}  // namespace
}  // namespace live_faults_test
