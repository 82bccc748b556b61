// dds.ros2's field layout (common/dds/src/ros2_layout.hpp, docs/ros2.md): topic names, stamps, the yaw
// quaternion and where an estimate's covariance (its z row in a 3-D world) goes in ROS's 6×6; and the MURP
// relative poses' (replay --murp --ros2): names, the full attitude quaternion and the 6×6 of a 4×4.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>
#include <numbers>

#include "../../../common/dds/src/ros2_layout.hpp"
#include "eigen_gtest.hpp"

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

TEST(Ros2Layout, MurpTopicsAndFramesNameTheVehiclesAsTheRunDirectoryDoes) {
  EXPECT_EQ(murp_vehicle_name(2), "vehicle_2");
  EXPECT_EQ(murp_pose_topic(1, 3), "rt/swarmloc/murp/vehicle_1/vehicle_3/pose");
  EXPECT_EQ(murp_truth_topic(3, 1), "rt/swarmloc/murp/vehicle_3/vehicle_1/truth");
  EXPECT_EQ(murp_level_frame(2), "vehicle_2/level");
  EXPECT_EQ(murp_stamp_ns(13.0), 13'000'000'000);
  EXPECT_EQ(murp_stamp_ns(0.1), 100'000'000);  // nearest, not truncated (0.1 · 1e9 = 99999999.99…)
}

/// Rz(yaw)·Ry(pitch)·Rx(roll) from Eigen's angle-axis rotations.
Mat3 eigen_zyx(double yaw_rad, double pitch_rad, double roll_rad) {
  return (Eigen::AngleAxisd(yaw_rad, Vec3::UnitZ()) * Eigen::AngleAxisd(pitch_rad, Vec3::UnitY()) *
          Eigen::AngleAxisd(roll_rad, Vec3::UnitX()))
      .toRotationMatrix();
}

TEST(Ros2Layout, AttitudeQuaternionIsRzRyRxAsEigenRotatesIt) {
  struct Angles {
    double yaw, pitch, roll;
  };
  // Headings beyond ±π/2 and beyond π, non-zero roll and pitch of either sign.
  for (const Angles& a : {Angles{0.3, 0.2, -0.1}, Angles{2.4, -0.35, 0.25}, Angles{-2.9, 0.15, 0.4},
                          Angles{3.6, 0.5, -0.45}, Angles{-1.7, -0.05, -0.3}}) {
    const auto q = attitude_quaternion(a.yaw, a.pitch, a.roll);
    const Eigen::Quaterniond quaternion(q[3], q[0], q[1], q[2]);
    EXPECT_NEAR(quaternion.norm(), 1.0, 1e-15);
    EXPECT_MATRIX_NEAR(quaternion.toRotationMatrix(), eigen_zyx(a.yaw, a.pitch, a.roll), 1e-14)
        << "yaw " << a.yaw << " pitch " << a.pitch << " roll " << a.roll;
    // relative_pose.hpp's frames: the peer's body -> my level frame is Rz(ψ)·T_peer, T = Ry(pitch)·Rx(roll).
    const Mat3 peer_body_to_level =
        estimators::uwb::yaw_rotation(a.yaw) * estimators::uwb::level_rotation({a.roll, a.pitch});
    EXPECT_MATRIX_NEAR(quaternion.toRotationMatrix(), peer_body_to_level, 1e-14);
  }
  // No tilt: the yaw quaternion exactly.
  EXPECT_EQ(attitude_quaternion(2.4, 0.0, 0.0), yaw_quaternion(2.4));
}

TEST(Ros2Layout, RelativePoseCovarianceMapsXyzHeadingToXyzRotZAndIsSymmetricPsd) {
  // A full, correlated 4×4 over (x, y, z, ψ): L·Lᵀ with every entry of L non-zero.
  estimators::uwb::Mat4 lower;
  lower << 0.3, 0, 0, 0, -0.1, 0.25, 0, 0, 0.05, 0.07, 0.12, 0, 0.02, -0.03, 0.04, 0.09;
  const estimators::uwb::Mat4 covariance = lower * lower.transpose();
  // An estimator's covariance is symmetric to rounding only: ROS gets the symmetric part.
  estimators::uwb::Mat4 rounded = covariance;
  rounded(0, 3) += 1e-17;
  rounded(3, 0) -= 1e-17;
  rounded(1, 2) *= 1.0 + 1e-15;
  const auto flat = relative_pose_covariance(rounded);
  const Eigen::Map<const Eigen::Matrix<double, 6, 6, Eigen::RowMajor>> ros(flat.data());
  constexpr std::array<int, 4> kRosAxis{0, 1, 2, 5};
  for (int row = 0; row < 4; ++row) {
    for (int col = 0; col < 4; ++col) {
      EXPECT_NEAR(ros(kRosAxis[static_cast<std::size_t>(row)], kRosAxis[static_cast<std::size_t>(col)]),
                  covariance(row, col), 1e-16)
          << "(" << row << ", " << col << ")";
    }
  }
  for (const int tilt : {3, 4}) {  // roll, pitch: not estimated
    EXPECT_EQ(ros(tilt, tilt), kUnknownVariance);
    for (int other = 0; other < 6; ++other) {
      if (other == tilt) continue;
      EXPECT_EQ(ros(tilt, other), 0.0);
      EXPECT_EQ(ros(other, tilt), 0.0);
    }
  }
  EXPECT_EQ((ros - ros.transpose()).cwiseAbs().maxCoeff(), 0.0);  // exactly
  for (int axis = 0; axis < 4; ++axis) {                          // the variances as they were
    const auto ros_axis = static_cast<Eigen::Index>(kRosAxis[static_cast<std::size_t>(axis)]);
    EXPECT_EQ(ros(ros_axis, ros_axis), covariance(axis, axis));
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eigen(Eigen::Matrix<double, 6, 6>{ros});
  EXPECT_GT(eigen.eigenvalues().minCoeff(), 0.0);  // L is full rank: positive definite
}

}  // namespace
}  // namespace swarmloc::dds::ros2
