// The UWB team's participants on loopback, in this process (as test_loopback.cpp; domain 38): what a
// hostile writer sends is rejected and counted by reason at every reader, and never delivered; samples for
// another vehicle are ignored, not rejected.
#include <gtest/gtest.h>

#include <limits>
#include <vector>

#include "dds_test_support.hpp"
#include "swarmloc/dds/uwb_team_io.hpp"

namespace swarmloc::dds {
namespace {

namespace uwb = estimators::uwb;
constexpr int kUwbTeamDomain = 38;
constexpr double kNotANumber = std::numeric_limits<double>::quiet_NaN();

UwbWindowInput window_for(AgentId vehicle, double roll_rad) {
  MatX ranges = MatX::Constant(2, 2, 3.5);
  ranges(0, 1) = kNotANumber;  // a missing range is no fault
  return {vehicle,
          0,
          0.0,
          0.0,
          false,
          uwb::VehicleSensing{{roll_rad, 0.0}, 0.0, 1.0},
          {{vehicle == 1 ? 2 : 1, ranges, MatX()}}};
}

UwbEstimates estimates_of(AgentId vehicle, double variance) {
  uwb::PoseEstimate estimate;
  estimate.covariance = uwb::Mat4::Identity() * variance;
  return {vehicle, 0, UwbRound::kOwn, {{vehicle == 1 ? 2 : 1, estimate}}};
}

TEST(UwbTeamIo, HostileSamplesAreRejectedAndCountedAndNeverDelivered) {
  const std::vector<AgentId> team{1, 2};
  UwbOrchestratorIo orchestrator({kUwbTeamDomain, team, kOrchestratorId});
  UwbVehicleIo one({kUwbTeamDomain, team, 1});
  UwbVehicleIo two({kUwbTeamDomain, team, 2});
  ASSERT_TRUE(test::poll_until(
      20.0, [&] { return orchestrator.matched() && one.matched_both_ways() && two.matched_both_ways(); }));

  orchestrator.publish_window(window_for(1, kNotANumber));  // hostile: a NaN roll
  orchestrator.publish_window(window_for(1, 0.125));
  orchestrator.publish_window(window_for(2, 0.25));    // vehicle two's: one ignores it
  two.publish_sensing({9, 0, uwb::VehicleSensing{}});  // a vehicle off the team
  two.publish_sensing({2, 0, uwb::VehicleSensing{}});
  two.publish_estimates(estimates_of(2, kNotANumber));  // hostile
  two.publish_estimates(estimates_of(2, 0.5));

  UwbVehicleInbound got;
  std::vector<UwbEstimates> reported;
  ASSERT_TRUE(test::poll_until(20.0, [&] {
    auto in = one.wait_and_take(0.05);
    got.inputs.insert(got.inputs.end(), in.inputs.begin(), in.inputs.end());
    got.sensing.insert(got.sensing.end(), in.sensing.begin(), in.sensing.end());
    got.estimates.insert(got.estimates.end(), in.estimates.begin(), in.estimates.end());
    auto taken = orchestrator.wait_and_take_estimates(0.0);
    reported.insert(reported.end(), taken.begin(), taken.end());
    return one.counters().received + one.counters().rejected + one.counters().ignored >= 7 &&
           orchestrator.counters().received + orchestrator.counters().rejected >= 2;
  }));

  const auto counters = one.counters();
  EXPECT_EQ(counters.rejected, 3U);
  EXPECT_EQ(counters.rejected_by_reason.at("non-finite or absurd reading"), 1U);
  EXPECT_EQ(counters.rejected_by_reason.at("unknown vehicle"), 1U);
  EXPECT_EQ(counters.rejected_by_reason.at("non-finite covariance"), 1U);
  EXPECT_EQ(counters.ignored, 1U);
  EXPECT_EQ(counters.received, 3U);
  ASSERT_EQ(got.inputs.size(), 1U);
  EXPECT_EQ(got.inputs[0].sensing->tilt.roll_rad, 0.125);
  ASSERT_EQ(got.sensing.size(), 1U);
  EXPECT_EQ(got.sensing[0].vehicle, 2);
  ASSERT_EQ(got.estimates.size(), 1U);
  EXPECT_EQ(got.estimates[0].peers.at(1).covariance(0, 0), 0.5);

  EXPECT_EQ(orchestrator.counters().rejected, 1U);
  ASSERT_EQ(reported.size(), 1U);
  EXPECT_EQ(reported[0].peers.at(1).covariance(3, 3), 0.5);
  EXPECT_EQ(two.counters().sent, 4U);
}

}  // namespace
}  // namespace swarmloc::dds
