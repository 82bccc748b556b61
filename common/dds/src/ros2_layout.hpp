#pragma once
// ROS 2 naming and field layout of what swarmloc publishes with dds.ros2 (docs/ros2.md). Free of IDL
// types so that unit tests can check the layout; ros2_bridge.cpp fills the wire samples from these.
#include <array>
#include <cstdint>
#include <string>

#include "swarmloc/estimators/uwb/relative_pose.hpp"
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

// MURP relative poses (`replay --murp --ros2`, docs/ros2.md, "MURP relative poses").

/// "vehicle_<id>": the run directory's name of a vehicle (agents/vehicle_<id>.log); a ROS name token must
/// not start with a digit.
std::string murp_vehicle_name(AgentId vehicle);
/// "rt/swarmloc/murp/vehicle_<observer>/vehicle_<peer>/pose": the observer's estimate of the peer.
std::string murp_pose_topic(AgentId observer, AgentId peer);
/// "rt/swarmloc/murp/vehicle_<observer>/vehicle_<peer>/truth": what the run scores that estimate against.
std::string murp_truth_topic(AgentId observer, AgentId peer);
/// "vehicle_<observer>/level": the observer's level frame (relative_pose.hpp: origin at its body origin, z
/// up, x along its heading).
std::string murp_level_frame(AgentId observer);
/// A trial time in seconds as a nanosecond stamp (rounded to the nearest nanosecond).
std::int64_t murp_stamp_ns(double time_s);

/// Quaternion (x, y, z, w) of Rz(yaw)·Ry(pitch)·Rx(roll): the product q_z(yaw)·q_y(pitch)·q_x(roll) of the
/// axis quaternions (as tf2's setRPY(roll, pitch, yaw)); unit norm, w < 0 possible beyond |yaw| = π.
std::array<double, 4> attitude_quaternion(double yaw_rad, double pitch_rad, double roll_rad);

/// The row-major 6×6 covariance over (x, y, z, rot x, rot y, rot z) of a relative pose estimate whose 4×4
/// covariance is over (x, y, z, ψ): its rows and columns go to x, y, z and rot z, symmetrized ((C + Cᵀ)/2:
/// an estimator's C is symmetric only to rounding); roll and pitch (the peer's IMU tilt, not estimated) get
/// kUnknownVariance and no correlation.
std::array<double, 36> relative_pose_covariance(const estimators::uwb::Mat4& covariance);

}  // namespace swarmloc::dds::ros2
