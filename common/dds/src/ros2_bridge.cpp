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

std_msgs_msg_dds__Header_ ros2_header_of(std::int64_t stamp_ns) {
  std_msgs_msg_dds__Header_ header{};
  const RosTime time = ros_time(stamp_ns);
  header.stamp.sec = time.sec;
  header.stamp.nanosec = time.nanosec;
  // dds_write only reads the string; the IDL's char* is not const.
  header.frame_id = const_cast<char*>(kFrameId);
  return header;
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
