// The UWB team's participants on loopback, in this process (as test_loopback.cpp; domain 38): what a
// hostile writer sends is rejected and counted by reason at every reader, and never delivered; samples for
// another vehicle are ignored, not rejected. The orchestrator's ROS 2 writers (replay --murp --ros2) exist
// only when asked for.
#include <dds/dds.h>
#include <gtest/gtest.h>

#include <limits>
#include <set>
#include <string>
#include <utility>
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

/// (topic, type) of every writer the DCPSPublication built-in topic shows on the team's domain in this
/// process (Cyclone lists local writers at once).
std::set<std::pair<std::string, std::string>> uwb_team_publications() {
  const dds_entity_t participant = dds_create_participant(kUwbTeamDomain, nullptr, nullptr);
  EXPECT_GT(participant, 0) << dds_strretcode(participant);
  const dds_entity_t reader =
      dds_create_reader(participant, DDS_BUILTIN_TOPIC_DCPSPUBLICATION, nullptr, nullptr);
  EXPECT_GT(reader, 0) << dds_strretcode(reader);
  std::set<std::pair<std::string, std::string>> publications;
  constexpr int kBatch = 64;
  void* samples[kBatch] = {};
  dds_sample_info_t infos[kBatch];
  int32_t count = 0;
  while ((count = dds_take(reader, samples, infos, kBatch, kBatch)) > 0) {
    for (int32_t i = 0; i < count; ++i) {
      if (!infos[i].valid_data) continue;
      const auto* endpoint = static_cast<const dds_builtintopic_endpoint_t*>(samples[i]);
      publications.emplace(endpoint->topic_name, endpoint->type_name);
    }
    dds_return_loan(reader, samples, count);
  }
  dds_delete(participant);
  return publications;
}

std::set<std::pair<std::string, std::string>> ros_topics_of(
    const std::set<std::pair<std::string, std::string>>& publications) {
  std::set<std::pair<std::string, std::string>> ros;
  for (const auto& publication : publications) {
    if (publication.first.starts_with("rt/")) ros.insert(publication);
  }
  return ros;
}

TEST(UwbTeamIo, OrchestratorWritesRosTopicsOnlyWithRos2AndUnderRos2TypeNames) {
  const std::vector<AgentId> team{1, 2, 3};
  {
    const UwbOrchestratorIo orchestrator({kUwbTeamDomain, team, kOrchestratorId});
    const auto publications = uwb_team_publications();
    // The reader does see the orchestrator's writers, so an empty ROS set means something.
    bool window_writer = false;
    for (const auto& publication : publications) window_writer |= publication.first == "swarmloc_uwb_window";
    EXPECT_TRUE(window_writer);
    EXPECT_TRUE(ros_topics_of(publications).empty());
    EXPECT_EQ(orchestrator.ros2_matched_readers(), 0);
  }
  const UwbOrchestratorIo orchestrator({kUwbTeamDomain, team, kOrchestratorId}, true);
  std::set<std::pair<std::string, std::string>> expected;
  for (const AgentId observer : team) {
    for (const AgentId peer : team) {
      if (peer == observer) continue;
      const std::string prefix =
          "rt/swarmloc/murp/vehicle_" + std::to_string(observer) + "/vehicle_" + std::to_string(peer);
      expected.emplace(prefix + "/pose", "geometry_msgs::msg::dds_::PoseWithCovarianceStamped_");
      expected.emplace(prefix + "/truth", "geometry_msgs::msg::dds_::PoseStamped_");
    }
  }
  EXPECT_EQ(ros_topics_of(uwb_team_publications()), expected);
  EXPECT_EQ(orchestrator.ros2_matched_readers(), 0);  // no ROS reader on the domain
}

}  // namespace
}  // namespace swarmloc::dds
