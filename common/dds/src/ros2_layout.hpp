#pragma once
// ROS 2 naming and field layout of what swarmloc publishes with dds.ros2 (docs/ros2.md). Free of IDL
// types so that unit tests can check the layout; ros2_bridge.cpp fills the wire samples from these.
#include <array>
#include <cstdint>
#include <string>

#include "swarmloc/runtime/envelope.hpp"

namespace swarmloc::dds::ros2 {

/// DDS topic names: "rt/" + the ROS name without its leading slash (rmw_cyclonedds' rule).
inline constexpr const char* kTruthTopic = "rt/swarmloc/truth";
inline constexpr const char* kRangesTopic = "rt/swarmloc/ranges";
/// "rt/swarmloc/agent_<id>/pose"
std::string pose_topic(AgentId agent);

/// Every pose and array is in this frame (the world's coordinates, metres).
inline constexpr const char* kFrameId = "map";
/// The variance of a pose coordinate swarmloc does not estimate (roll, pitch; z in a planar world; yaw
/// without a heading):
/// large enough for any ROS consumer to ignore the coordinate.
inline constexpr double kUnknownVariance = 1e9;

/// builtin_interfaces/Time of a nanosecond stamp: sec = ⌊ns / 1e9⌋, nanosec in [0, 1e9).
struct RosTime {
  std::int32_t sec = 0;
  std::uint32_t nanosec = 0;
};
RosTime ros_time(std::int64_t stamp_ns);

/// Quaternion (x, y, z, w) of a rotation by `yaw_rad` about z.
std::array<double, 4> yaw_quaternion(double yaw_rad);

/// The row-major 6×6 covariance over (x, y, z, rot x, rot y, rot z) of an estimate: the x-y block from the
/// estimate, z's row and column from its altitude (a 3-D world) and yaw's from its heading if it has them,
/// every other diagonal entry kUnknownVariance, every other off-diagonal entry 0.
std::array<double, 36> pose_covariance(const estimators::Estimate& estimate);

/// Whether a report becomes a ROS 2 pose: a valid estimate from a step the agent ran (not a hello).
inline bool publishes_pose(const runtime::EstimateReport& report) {
  return report.steps_run > 0 && report.estimate.valid;
}

}  // namespace swarmloc::dds::ros2
