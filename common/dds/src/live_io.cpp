// Live agents' and the monitor's ROS 2 topics (live_io.hpp, docs/live.md).
#include "swarmloc/dds/live_io.hpp"

#include <cmath>

#include "endpoints.hpp"
#include "ros2_bridge.hpp"

namespace swarmloc::dds {
namespace {

/// Samples taken per dds_take call.
constexpr std::uint32_t kLiveTakeBatch = 32;
/// Keep-last depth of the driver readers: a burst of sweeps between two takes is not lost.
constexpr int kLiveReaderDepth = 64;

std::int64_t live_stamp_ns(const builtin_interfaces_msg_dds__Time_& stamp) {
  return static_cast<std::int64_t>(stamp.sec) * 1'000'000'000 + static_cast<std::int64_t>(stamp.nanosec);
}

double live_yaw(const geometry_msgs_msg_dds__Quaternion_& q) {
  return std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
}

/// Takes every valid sample of `reader` and hands each to `use` (typed by the caller).
template <typename Sample, typename Use>
void live_take_all(dds_entity_t reader, Use&& use) {
  for (;;) {
    void* samples[kLiveTakeBatch] = {};
    dds_sample_info_t infos[kLiveTakeBatch];
    const dds_return_t n = dds_take(reader, samples, infos, kLiveTakeBatch, kLiveTakeBatch);
    if (n <= 0) return;
    for (dds_return_t k = 0; k < n; ++k) {
      const auto index = static_cast<std::size_t>(k);
      if (infos[index].valid_data) use(*static_cast<const Sample*>(samples[index]));
    }
    dds_return_loan(reader, samples, n);
    if (n < static_cast<dds_return_t>(kLiveTakeBatch)) return;
  }
}

/// The header of a live output sample; dds_write only reads the frame string.
std_msgs_msg_dds__Header_ live_header(std::int64_t stamp_ns, const std::string& frame) {
  std_msgs_msg_dds__Header_ header{};
  const ros2::RosTime time = ros2::ros_time(stamp_ns);
  header.stamp.sec = time.sec;
  header.stamp.nanosec = time.nanosec;
  header.frame_id = const_cast<char*>(frame.c_str());
  return header;
}

}  // namespace

// ===================================================================================================
// Robot

struct LiveRobotIo::Impl {
  Impl(const config::Scenario& scenario, const Topology& topology, const LiveNames& live_names)
      : names(live_names),
        domain(static_cast<dds_domainid_t>(scenario.dds.domain_id), cyclone_config(scenario, topology)),
        participant(create_participant(domain)) {
    const dds_entity_t pp = participant.get();
    ranges = ros2::create_reader(pp, swarmloc_msgs_msg_dds__RangeArray__desc, names.ranges_topic,
                                 kLiveReaderDepth);
    odom = ros2::create_reader(pp, nav_msgs_msg_dds__Odometry__desc, names.odom_topic, kLiveReaderDepth);
    pose = ros2::create_writer(pp, geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc, names.pose_topic);
    tf = ros2::create_writer(pp, tf2_msgs_msg_dds__TFMessage__desc, names.tf_topic);
  }

  LiveNames names;
  DomainLease domain;  // declared before the participant: released after it
  Entity participant;
  dds_entity_t ranges = 0;
  dds_entity_t odom = 0;
  dds_entity_t pose = 0;
  dds_entity_t tf = 0;
};

LiveRobotIo::LiveRobotIo(const config::Scenario& scenario, const Topology& topology, const LiveNames& names)
    : impl_(std::make_unique<Impl>(scenario, topology, names)) {}

LiveRobotIo::~LiveRobotIo() = default;

std::vector<RangeSweep> LiveRobotIo::take_ranges() {
  std::vector<RangeSweep> sweeps;
  live_take_all<swarmloc_msgs_msg_dds__RangeArray_>(impl_->ranges, [&sweeps](const auto& sample) {
    RangeSweep sweep;
    sweep.stamp_ns = live_stamp_ns(sample.header.stamp);
    sweep.sweep = sample.step;
    for (std::uint32_t k = 0; k < sample.ranges._length; ++k) {
      const auto& range = sample.ranges._buffer[k];
      sweep.ranges.push_back({range.peer, range.range_m, range.std_m});
      sweep.measured_by.push_back(range.agent);
    }
    sweeps.push_back(std::move(sweep));
  });
  return sweeps;
}

std::vector<OdomSample> LiveRobotIo::take_odom() {
  std::vector<OdomSample> odometry;
  live_take_all<nav_msgs_msg_dds__Odometry_>(impl_->odom, [&odometry](const auto& sample) {
    OdomSample odom;
    odom.stamp_ns = live_stamp_ns(sample.header.stamp);
    odom.position_m = Vec2(sample.pose.pose.position.x, sample.pose.pose.position.y);
    odom.yaw_rad = live_yaw(sample.pose.pose.orientation);
    odom.speed_mps = sample.twist.twist.linear.x;
    odom.yaw_rate_rps = sample.twist.twist.angular.z;
    odometry.push_back(odom);
  });
  return odometry;
}

void LiveRobotIo::publish_pose(const runtime::EstimateReport& report, std::int64_t stamp_ns) {
  ros2::WirePose pose(report);
  pose.sample.header = live_header(stamp_ns, impl_->names.map_frame);
  check(dds_write(impl_->pose, &pose.sample), "dds_write", impl_->names.pose_topic);

  geometry_msgs_msg_dds__TransformStamped_ transform{};
  transform.header = live_header(stamp_ns, impl_->names.map_frame);
  transform.child_frame_id = const_cast<char*>(impl_->names.base_frame.c_str());
  transform.transform.translation.x = pose.sample.pose.pose.position.x;
  transform.transform.translation.y = pose.sample.pose.pose.position.y;
  transform.transform.rotation = pose.sample.pose.pose.orientation;
  tf2_msgs_msg_dds__TFMessage_ message{};
  message.transforms._maximum = message.transforms._length = 1;
  message.transforms._buffer = &transform;
  message.transforms._release = false;
  check(dds_write(impl_->tf, &message), "dds_write", impl_->names.tf_topic);
}

int LiveRobotIo::matched_range_writers() const {
  dds_subscription_matched_status_t status{};
  if (dds_get_subscription_matched_status(impl_->ranges, &status) < 0) return 0;
  return static_cast<int>(status.current_count);
}

// ===================================================================================================
// Monitor

struct LiveMonitorIo::Impl {
  Impl(const config::Scenario& scenario, int agent_count, const std::vector<std::string>& pose_topics,
       const std::vector<std::string>& truth_topics)
      : domain(static_cast<dds_domainid_t>(scenario.dds.domain_id),
               cyclone_config(scenario, Topology{kOrchestratorId, agent_count, {}})),
        participant(create_participant(domain)) {
    const dds_entity_t pp = participant.get();
    for (const auto& topic : pose_topics) {
      poses.push_back(ros2::create_reader(pp, geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc, topic,
                                          kLiveReaderDepth));
    }
    for (const auto& topic : truth_topics) {
      truth.push_back(topic.empty() ? 0
                                    : ros2::create_reader(pp, geometry_msgs_msg_dds__PoseStamped__desc, topic,
                                                          kLiveReaderDepth));
    }
  }

  DomainLease domain;
  Entity participant;
  std::vector<dds_entity_t> poses;
  std::vector<dds_entity_t> truth;  ///< 0: that robot has no truth topic
};

LiveMonitorIo::LiveMonitorIo(const config::Scenario& scenario, int agent_count,
                             const std::vector<std::string>& pose_topics,
                             const std::vector<std::string>& truth_topics)
    : impl_(std::make_unique<Impl>(scenario, agent_count, pose_topics, truth_topics)) {}

LiveMonitorIo::~LiveMonitorIo() = default;

void LiveMonitorIo::wait(double timeout_s) { dds_sleepfor(to_duration(timeout_s)); }

std::vector<StampedPose> LiveMonitorIo::take_poses() {
  std::vector<StampedPose> taken;
  for (std::size_t robot = 0; robot < impl_->poses.size(); ++robot) {
    live_take_all<geometry_msgs_msg_dds__PoseWithCovarianceStamped_>(
        impl_->poses[robot], [&taken, robot](const auto& sample) {
          const auto& pose = sample.pose.pose;
          const double* cov = sample.pose.covariance;  // row-major 6x6: x-y block at 0, 1, 6, 7
          Mat2 covariance;
          covariance << cov[0], cov[1], cov[6], cov[7];
          taken.push_back({robot, live_stamp_ns(sample.header.stamp), Vec2(pose.position.x, pose.position.y),
                           live_yaw(pose.orientation), covariance});
        });
  }
  return taken;
}

std::vector<StampedPose> LiveMonitorIo::take_truth() {
  std::vector<StampedPose> taken;
  for (std::size_t robot = 0; robot < impl_->truth.size(); ++robot) {
    if (impl_->truth[robot] == 0) continue;
    live_take_all<geometry_msgs_msg_dds__PoseStamped_>(
        impl_->truth[robot], [&taken, robot](const auto& sample) {
          taken.push_back({robot, live_stamp_ns(sample.header.stamp),
                           Vec2(sample.pose.position.x, sample.pose.position.y),
                           live_yaw(sample.pose.orientation), Mat2::Zero()});
        });
  }
  return taken;
}

}  // namespace swarmloc::dds
