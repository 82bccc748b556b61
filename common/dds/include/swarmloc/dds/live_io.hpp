#pragma once
// ROS 2 topics of live agents (docs/live.md): a robot's drivers publish its ranges and odometry, its
// agent publishes its pose and its tf transform; the monitor reads every robot's pose and, if present,
// its ground truth. Plain types here; the IDL samples stay in common/dds/src.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/dds/transport.hpp"
#include "swarmloc/runtime/envelope.hpp"

namespace swarmloc::dds {

/// The ROS 2 names one live robot uses: DDS topic names ("rt/<robot>/ranges") and tf frame ids.
struct LiveNames {
  std::string ranges_topic;
  std::string odom_topic;
  std::string pose_topic;
  std::string tf_topic = "rt/tf";
  std::string map_frame = "map";
  std::string base_frame;  ///< "<robot>/base_link"
};

/// One swarmloc_msgs/RangeArray from the robot's range driver.
struct RangeSweep {
  std::int64_t stamp_ns = 0;  ///< header.stamp: the robot's clock
  std::int64_t sweep = 0;     ///< the driver's counter (field `step`)
  std::vector<estimators::RangeMeasurement> ranges;
  std::vector<AgentId> measured_by;  ///< each range's field `agent`: the robot that measured it
};

/// One nav_msgs/Odometry: the pose in the odometry frame and the body-frame twist.
struct OdomSample {
  std::int64_t stamp_ns = 0;
  Vec2 position_m = Vec2::Zero();
  double yaw_rad = 0.0;
  double speed_mps = 0.0;  ///< twist.linear.x
  double yaw_rate_rps = 0.0;
};

/// One 2-D pose read from a ROS 2 pose topic (PoseWithCovarianceStamped or PoseStamped).
struct StampedPose {
  std::size_t robot = 0;  ///< index into the topic list the reader was built with
  std::int64_t stamp_ns = 0;
  Vec2 position_m = Vec2::Zero();
  double yaw_rad = 0.0;
  Mat2 covariance = Mat2::Zero();  ///< the x-y block (PoseWithCovarianceStamped; zero for PoseStamped)
};

/// A live agent's ROS 2 side: its driver topics in, its pose and tf out. Shares the process's Cyclone
/// domain with the agent's AgentTransport (same scenario and topology: same configuration).
class LiveRobotIo {
 public:
  LiveRobotIo(const config::Scenario& scenario, const Topology& topology, const LiveNames& names);
  ~LiveRobotIo();
  LiveRobotIo(const LiveRobotIo&) = delete;
  LiveRobotIo& operator=(const LiveRobotIo&) = delete;

  /// Every range sweep and odometry sample received since the last call, in arrival order.
  std::vector<RangeSweep> take_ranges();
  std::vector<OdomSample> take_odom();
  /// The estimate as PoseWithCovarianceStamped on the pose topic and as the map → base transform on tf,
  /// both stamped `stamp_ns` (the robot's clock).
  void publish_pose(const runtime::EstimateReport& report, std::int64_t stamp_ns);
  /// Writers whose readers matched our range reader (a driver is up).
  [[nodiscard]] int matched_range_writers() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The monitor's ROS 2 side: a pose reader per robot and, where given, a truth reader
/// (geometry_msgs/PoseStamped, e.g. motion capture).
class LiveMonitorIo {
 public:
  LiveMonitorIo(const config::Scenario& scenario, int agent_count,
                const std::vector<std::string>& pose_topics, const std::vector<std::string>& truth_topics);
  ~LiveMonitorIo();
  LiveMonitorIo(const LiveMonitorIo&) = delete;
  LiveMonitorIo& operator=(const LiveMonitorIo&) = delete;

  /// Blocks up to timeout_s for data, then takes every pose and truth sample received.
  void wait(double timeout_s);
  std::vector<StampedPose> take_poses();
  std::vector<StampedPose> take_truth();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace swarmloc::dds
