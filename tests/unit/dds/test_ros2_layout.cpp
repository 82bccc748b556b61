// dds.ros2's field layout (common/dds/src/ros2_layout.hpp, docs/ros2.md): topic names, stamps, the yaw
// quaternion and where an estimate's covariance (its z row in a 3-D world) goes in ROS's 6×6.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "../../../common/dds/src/ros2_layout.hpp"

namespace swarmloc::dds::ros2 {
namespace {

TEST(Ros2Layout, TopicNamesFollowRmwCycloneddsRules) {
  EXPECT_EQ(pose_topic(3), "rt/swarmloc/agent_3/pose");
  EXPECT_STREQ(kTruthTopic, "rt/swarmloc/truth");
  EXPECT_STREQ(kRangesTopic, "rt/swarmloc/ranges");
  EXPECT_STREQ(kFrameId, "map");
}

TEST(Ros2Layout, StampsSplitIntoSecondsAndNanosecondsRoundingDown) {
  EXPECT_EQ(ros_time(12'345'678'901).sec, 12);
  EXPECT_EQ(ros_time(12'345'678'901).nanosec, 345'678'901U);
  EXPECT_EQ(ros_time(0).sec, 0);
  EXPECT_EQ(ros_time(0).nanosec, 0U);
  // A negative stamp (an agent clock offset below zero): nanosec stays in [0, 1e9).
  EXPECT_EQ(ros_time(-1).sec, -1);
  EXPECT_EQ(ros_time(-1).nanosec, 999'999'999U);
  EXPECT_EQ(ros_time(-2'000'000'000).sec, -2);
  EXPECT_EQ(ros_time(-2'000'000'000).nanosec, 0U);
}

TEST(Ros2Layout, YawQuaternionRotatesAboutZ) {
  const auto identity = yaw_quaternion(0.0);
  EXPECT_EQ(identity, (std::array<double, 4>{0.0, 0.0, 0.0, 1.0}));
  const auto quarter = yaw_quaternion(std::numbers::pi / 2);
  EXPECT_DOUBLE_EQ(quarter[2], std::sqrt(0.5));
  EXPECT_DOUBLE_EQ(quarter[3], std::sqrt(0.5));
  EXPECT_EQ(quarter[0], 0.0);
  EXPECT_EQ(quarter[1], 0.0);
}

TEST(Ros2Layout, PositionOnlyCovarianceFillsTheXyBlockAndMarksTheRestUnknown) {
  estimators::Estimate estimate;
  estimate.covariance << 4.0, 0.5, 0.5, 9.0;
  const auto covariance = pose_covariance(estimate);
  EXPECT_EQ(covariance[0], 4.0);  // (x, x)
  EXPECT_EQ(covariance[1], 0.5);  // (x, y)
  EXPECT_EQ(covariance[6], 0.5);  // (y, x)
  EXPECT_EQ(covariance[7], 9.0);  // (y, y)
  for (const int diagonal : {14, 21, 28, 35})
    EXPECT_EQ(covariance[static_cast<std::size_t>(diagonal)], kUnknownVariance);
  double off_block = 0.0;
  for (int row = 0; row < 6; ++row) {
    for (int col = 0; col < 6; ++col) {
      if (row != col && (row >= 2 || col >= 2))
        off_block += std::abs(covariance[static_cast<std::size_t>(6 * row + col)]);
    }
  }
  EXPECT_EQ(off_block, 0.0);
}

TEST(Ros2Layout, HeadingFillsYawsRowAndColumn) {
  estimators::Estimate estimate;
  estimate.covariance << 4.0, 0.5, 0.5, 9.0;
  estimate.heading = estimators::HeadingEstimate{1.0, 0.01, Vec2(0.02, -0.03)};
  const auto covariance = pose_covariance(estimate);
  EXPECT_EQ(covariance[35], 0.01);   // (yaw, yaw)
  EXPECT_EQ(covariance[5], 0.02);    // (x, yaw)
  EXPECT_EQ(covariance[30], 0.02);   // (yaw, x)
  EXPECT_EQ(covariance[11], -0.03);  // (y, yaw)
  EXPECT_EQ(covariance[31], -0.03);  // (yaw, y)
  for (const int diagonal : {14, 21, 28})
    EXPECT_EQ(covariance[static_cast<std::size_t>(diagonal)], kUnknownVariance);
}

TEST(Ros2Layout, AltitudeFillsZsRowAndColumn) {
  estimators::Estimate estimate;
  estimate.covariance << 4.0, 0.5, 0.5, 9.0;
  estimate.altitude = Altitude{7.0, 0.25, Vec2(0.04, -0.06)};
  const auto covariance = pose_covariance(estimate);
  EXPECT_EQ(covariance[14], 0.25);   // (z, z)
  EXPECT_EQ(covariance[2], 0.04);    // (x, z)
  EXPECT_EQ(covariance[12], 0.04);   // (z, x)
  EXPECT_EQ(covariance[8], -0.06);   // (y, z)
  EXPECT_EQ(covariance[13], -0.06);  // (z, y)
  for (const int diagonal : {21, 28, 35})
    EXPECT_EQ(covariance[static_cast<std::size_t>(diagonal)], kUnknownVariance);
}

TEST(Ros2Layout, OnlyValidEstimatesOfStepsRunBecomePoses) {
  runtime::EstimateReport report;
  report.estimate.valid = true;
  EXPECT_FALSE(publishes_pose(report));  // a hello (steps_run = 0) carries the prior
  report.steps_run = 1;
  EXPECT_TRUE(publishes_pose(report));
  report.estimate.valid = false;
  EXPECT_FALSE(publishes_pose(report));
}

}  // namespace
}  // namespace swarmloc::dds::ros2
