// swarmloc types -> ROS 2 samples (idl/ros2.idl) and their writers (docs/ros2.md).
#include "ros2_bridge.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "endpoints.hpp"
#include "entities.hpp"
#include "qos.hpp"

namespace swarmloc::dds::ros2 {

namespace {

/// `descriptor` without its XTypes type information, so that ROS 2 readers match on the type name alone,
/// as rmw_cyclonedds' own writers do. With it, a Cyclone 0.10.2 reader whose IDL declares
/// `double covariance[36]` through a typedef (as rosidl's generated IDL does) was found not to match
/// (docs/ros2.md, "Type information"). Copies live as long as the process (topics refer to them).
const dds_topic_descriptor_t& ros2_descriptor_without_type_information(
    const dds_topic_descriptor_t& descriptor) {
  static std::mutex copies_mutex;
  static std::map<const dds_topic_descriptor_t*, std::unique_ptr<dds_topic_descriptor_t>> copies;
  const std::lock_guard lock(copies_mutex);
  auto& copy = copies[&descriptor];
  if (!copy) {
    copy = std::make_unique<dds_topic_descriptor_t>(dds_topic_descriptor_t{
        descriptor.m_size, descriptor.m_align, descriptor.m_flagset & ~DDS_TOPIC_XTYPES_METADATA,
        descriptor.m_nkeys, descriptor.m_typename, descriptor.m_keys, descriptor.m_nops, descriptor.m_ops,
        descriptor.m_meta, dds_type_meta_ser{nullptr, 0}, dds_type_meta_ser{nullptr, 0},
        descriptor.restrict_data_representation});
  }
  return *copy;
}

/// `frame_id` must outlive the header's use.
std_msgs_msg_dds__Header_ ros2_header_of(std::int64_t stamp_ns, const char* frame_id = kFrameId) {
  std_msgs_msg_dds__Header_ header{};
  const RosTime time = ros_time(stamp_ns);
  header.stamp.sec = time.sec;
  header.stamp.nanosec = time.nanosec;
  // dds_write only reads the string; the IDL's char* is not const.
  header.frame_id = const_cast<char*>(frame_id);
  return header;
}

/// A relative pose (position, heading ψ) with the peer's tilt as a geometry_msgs/Pose.
geometry_msgs_msg_dds__Pose_ relative_pose_of(const estimators::uwb::RelativePose& pose,
                                              const estimators::uwb::Tilt& peer_tilt) {
  geometry_msgs_msg_dds__Pose_ out{};
  out.position.x = pose.position_m.x();
  out.position.y = pose.position_m.y();
  out.position.z = pose.position_m.z();
  const auto quaternion = attitude_quaternion(pose.heading_rad, peer_tilt.pitch_rad, peer_tilt.roll_rad);
  out.orientation.x = quaternion[0];
  out.orientation.y = quaternion[1];
  out.orientation.z = quaternion[2];
  out.orientation.w = quaternion[3];
  return out;
}

}  // namespace

std::string pose_topic(AgentId agent) { return "rt/swarmloc/agent_" + std::to_string(agent) + "/pose"; }

RosTime ros_time(std::int64_t stamp_ns) {
  constexpr std::int64_t kNsPerS = 1'000'000'000;
  std::int64_t sec = stamp_ns / kNsPerS;
  std::int64_t nanosec = stamp_ns % kNsPerS;
  if (nanosec < 0) {  // floor, as builtin_interfaces/Time wants nanosec in [0, 1e9)
    nanosec += kNsPerS;
    --sec;
  }
  return RosTime{static_cast<std::int32_t>(sec), static_cast<std::uint32_t>(nanosec)};
}

std::array<double, 4> yaw_quaternion(double yaw_rad) {
  return {0.0, 0.0, std::sin(0.5 * yaw_rad), std::cos(0.5 * yaw_rad)};
}

std::array<double, 36> pose_covariance(const estimators::Estimate& estimate) {
  constexpr int kX = 0, kY = 1, kZ = 2, kYaw = 5, kSize = 6;
  std::array<double, 36> covariance{};
  auto at = [&covariance](int row, int col) -> double& {
    const int index = row * kSize + col;
    return covariance[static_cast<std::size_t>(index)];
  };
  for (int axis = 0; axis < kSize; ++axis) at(axis, axis) = kUnknownVariance;
  at(kX, kX) = estimate.covariance(0, 0);
  at(kX, kY) = estimate.covariance(0, 1);
  at(kY, kX) = estimate.covariance(1, 0);
  at(kY, kY) = estimate.covariance(1, 1);
  if (estimate.altitude) {  // a 3-D world: z's row and column
    at(kZ, kZ) = estimate.altitude->variance_m2;
    at(kX, kZ) = at(kZ, kX) = estimate.altitude->cross_m2.x();
    at(kY, kZ) = at(kZ, kY) = estimate.altitude->cross_m2.y();
  }
  if (estimate.heading) {
    at(kYaw, kYaw) = estimate.heading->variance_rad2;
    at(kX, kYaw) = at(kYaw, kX) = estimate.heading->position_cov_m_rad.x();
    at(kY, kYaw) = at(kYaw, kY) = estimate.heading->position_cov_m_rad.y();
  }
  return covariance;
}

std::string murp_vehicle_name(AgentId vehicle) { return "vehicle_" + std::to_string(vehicle); }

std::string murp_pose_topic(AgentId observer, AgentId peer) {
  return "rt/swarmloc/murp/" + murp_vehicle_name(observer) + "/" + murp_vehicle_name(peer) + "/pose";
}

std::string murp_truth_topic(AgentId observer, AgentId peer) {
  return "rt/swarmloc/murp/" + murp_vehicle_name(observer) + "/" + murp_vehicle_name(peer) + "/truth";
}

std::string murp_level_frame(AgentId observer) { return murp_vehicle_name(observer) + "/level"; }

std::int64_t murp_stamp_ns(double time_s) { return std::llround(time_s * 1e9); }

std::array<double, 4> attitude_quaternion(double yaw_rad, double pitch_rad, double roll_rad) {
  const double cy = std::cos(0.5 * yaw_rad), sy = std::sin(0.5 * yaw_rad);
  const double cp = std::cos(0.5 * pitch_rad), sp = std::sin(0.5 * pitch_rad);
  const double cr = std::cos(0.5 * roll_rad), sr = std::sin(0.5 * roll_rad);
  // q_z(yaw)·q_y(pitch)·q_x(roll), (x, y, z, w)
  return {sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
          cr * cp * cy + sr * sp * sy};
}

std::array<double, 36> relative_pose_covariance(const estimators::uwb::Mat4& covariance) {
  constexpr int kSize = 6;
  constexpr std::array<int, 4> kAxisOf{0, 1, 2, 5};  // x, y, z, ψ -> x, y, z, rot z
  std::array<double, 36> out{};
  constexpr std::size_t kRollDiagonal = 3 * kSize + 3, kPitchDiagonal = 4 * kSize + 4;
  out[kRollDiagonal] = out[kPitchDiagonal] = kUnknownVariance;
  for (int row = 0; row < 4; ++row) {
    for (int col = 0; col < 4; ++col) {
      const int index =
          kAxisOf[static_cast<std::size_t>(row)] * kSize + kAxisOf[static_cast<std::size_t>(col)];
      out[static_cast<std::size_t>(index)] = 0.5 * (covariance(row, col) + covariance(col, row));
    }
  }
  return out;
}

WireRelativePose::WireRelativePose(AgentId observer, double time_s,
                                   const estimators::uwb::PoseEstimate& estimate,
                                   const estimators::uwb::Tilt& peer_tilt)
    : frame_id(murp_level_frame(observer)) {
  sample.header = ros2_header_of(murp_stamp_ns(time_s), frame_id.c_str());
  sample.pose.pose = relative_pose_of(estimate.pose, peer_tilt);
  const auto covariance = relative_pose_covariance(estimate.covariance);
  std::copy(covariance.begin(), covariance.end(), sample.pose.covariance);
}

WireRelativeTruth::WireRelativeTruth(AgentId observer, double time_s,
                                     const estimators::uwb::RelativePose& truth,
                                     const estimators::uwb::Tilt& peer_tilt)
    : frame_id(murp_level_frame(observer)) {
  sample.header = ros2_header_of(murp_stamp_ns(time_s), frame_id.c_str());
  sample.pose = relative_pose_of(truth, peer_tilt);
}

WirePose::WirePose(const runtime::EstimateReport& report) {
  const estimators::Estimate& estimate = report.estimate;
  sample.header = ros2_header_of(report.header.sender_stamp_ns);
  auto& pose = sample.pose.pose;
  pose.position.x = estimate.mean_m.x();
  pose.position.y = estimate.mean_m.y();
  pose.position.z = estimate.altitude ? estimate.altitude->z_m : 0.0;
  const auto quaternion = yaw_quaternion(estimate.heading ? estimate.heading->heading_rad : 0.0);
  pose.orientation.x = quaternion[0];
  pose.orientation.y = quaternion[1];
  pose.orientation.z = quaternion[2];
  pose.orientation.w = quaternion[3];
  const auto covariance = pose_covariance(estimate);
  std::copy(covariance.begin(), covariance.end(), sample.pose.covariance);
}

WirePoseArray::WirePoseArray(std::int64_t world_stamp_ns, const std::vector<Vec2>& truth,
                             const std::vector<double>& z) {
  poses.resize(truth.size());
  for (std::size_t i = 0; i < truth.size(); ++i) {
    poses[i] = geometry_msgs_msg_dds__Pose_{};
    poses[i].position.x = truth[i].x();
    poses[i].position.y = truth[i].y();
    poses[i].position.z = i < z.size() ? z[i] : 0.0;
    poses[i].orientation.w = 1.0;
  }
  sample.header = ros2_header_of(world_stamp_ns);
  sample.poses._maximum = sample.poses._length = static_cast<uint32_t>(poses.size());
  sample.poses._buffer = poses.empty() ? nullptr : poses.data();
  sample.poses._release = false;
}

WireRangeArray::WireRangeArray(std::int64_t step, std::int64_t world_stamp_ns,
                               const std::vector<estimators::MeasurementBatch>& batches) {
  for (std::size_t agent = 0; agent < batches.size(); ++agent) {
    for (const auto& range : batches[agent].ranges) {
      ranges.push_back(
          swarmloc_msgs_msg_dds__Range_{static_cast<int32_t>(agent), range.peer, range.range_m, range.std_m});
    }
  }
  sample.header = ros2_header_of(world_stamp_ns);
  sample.step = step;
  sample.ranges._maximum = sample.ranges._length = static_cast<uint32_t>(ranges.size());
  sample.ranges._buffer = ranges.empty() ? nullptr : ranges.data();
  sample.ranges._release = false;
}

namespace {

/// ROS 2's default profile (rmw_qos_profile_default): reliable, keep-last `depth`, volatile.
QosPtr ros2_default_qos(int depth) {
  config::QosSettings ros2_default;
  ros2_default.reliability = config::Reliability::kReliable;
  ros2_default.history_depth = depth;
  ros2_default.durability = config::Durability::kVolatile;
  ros2_default.deadline_s = 0.0;
  ros2_default.liveliness_lease_s = 0.0;
  return endpoint_qos(ros2_default);
}

}  // namespace

dds_entity_t create_writer(dds_entity_t participant, const dds_topic_descriptor_t& descriptor,
                           const std::string& topic) {
  const dds_entity_t handle =
      dds::create_topic(participant, ros2_descriptor_without_type_information(descriptor), topic.c_str());
  const auto qos = ros2_default_qos(10);
  // No publisher QoS: the default partition, the one ROS 2 uses (not this run's "<run_id>.…" ones).
  return check(dds_create_writer(participant, handle, qos.get(), nullptr), "dds_create_writer", topic);
}

dds_entity_t create_reader(dds_entity_t participant, const dds_topic_descriptor_t& descriptor,
                           const std::string& topic, int depth) {
  const dds_entity_t handle =
      dds::create_topic(participant, ros2_descriptor_without_type_information(descriptor), topic.c_str());
  const auto qos = ros2_default_qos(depth);
  return check(dds_create_reader(participant, handle, qos.get(), nullptr), "dds_create_reader", topic);
}

}  // namespace swarmloc::dds::ros2
