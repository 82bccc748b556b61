#pragma once
// ROS 2 samples (idl/ros2.idl) from swarmloc types, and the writers that publish them (docs/ros2.md).
// Like convert.hpp's Wire* types, each holds its IDL sample plus the buffers the sample points into,
// and must outlive the dds_write call.
#include <dds/dds.h>

#include <string>
#include <vector>

#include "ros2.h"
#include "ros2_layout.hpp"
#include "swarmloc/config/scenario.hpp"

namespace swarmloc::dds::ros2 {

/// geometry_msgs/PoseWithCovarianceStamped of one estimate report, stamped with the reporter's clock
/// (header.sender_stamp_ns).
struct WirePose {
  explicit WirePose(const runtime::EstimateReport& report);
  WirePose(const WirePose&) = delete;
  WirePose& operator=(const WirePose&) = delete;
  geometry_msgs_msg_dds__PoseWithCovarianceStamped_ sample{};
};

/// geometry_msgs/PoseArray of the true positions (poses[i] = agent i, identity orientation; z from `z` in a
/// 3-D world, else 0).
struct WirePoseArray {
  WirePoseArray(std::int64_t world_stamp_ns, const std::vector<Vec2>& truth, const std::vector<double>& z);
  WirePoseArray(const WirePoseArray&) = delete;
  WirePoseArray& operator=(const WirePoseArray&) = delete;
  std::vector<geometry_msgs_msg_dds__Pose_> poses;
  geometry_msgs_msg_dds__PoseArray_ sample{};
};

/// swarmloc_msgs/RangeArray of one world step: every agent's ranges (batches[i] = agent i's).
struct WireRangeArray {
  WireRangeArray(std::int64_t step, std::int64_t world_stamp_ns,
                 const std::vector<estimators::MeasurementBatch>& batches);
  WireRangeArray(const WireRangeArray&) = delete;
  WireRangeArray& operator=(const WireRangeArray&) = delete;
  std::vector<swarmloc_msgs_msg_dds__Range_> ranges;
  swarmloc_msgs_msg_dds__RangeArray_ sample{};
};

/// geometry_msgs/PoseWithCovarianceStamped of a MURP relative pose estimate (docs/ros2.md, "MURP relative
/// poses"): the peer in `observer`'s level frame at trial time `time_s`, oriented Rz(ψ)·Ry(pitch)·Rx(roll)
/// with the peer's roll and pitch `peer_tilt`; covariance relative_pose_covariance.
struct WireRelativePose {
  WireRelativePose(AgentId observer, double time_s, const estimators::uwb::PoseEstimate& estimate,
                   const estimators::uwb::Tilt& peer_tilt);
  WireRelativePose(const WireRelativePose&) = delete;
  WireRelativePose& operator=(const WireRelativePose&) = delete;
  std::string frame_id;
  geometry_msgs_msg_dds__PoseWithCovarianceStamped_ sample{};
};

/// geometry_msgs/PoseStamped of a MURP relative pose's truth, laid out as WireRelativePose.
struct WireRelativeTruth {
  WireRelativeTruth(AgentId observer, double time_s, const estimators::uwb::RelativePose& truth,
                    const estimators::uwb::Tilt& peer_tilt);
  WireRelativeTruth(const WireRelativeTruth&) = delete;
  WireRelativeTruth& operator=(const WireRelativeTruth&) = delete;
  std::string frame_id;
  geometry_msgs_msg_dds__PoseStamped_ sample{};
};

/// A writer on ROS 2 topic `topic` (DDS name, "rt/…") of type `descriptor`, in the default partition
/// (where ROS 2 reads) with ROS 2's default QoS: reliable, keep-last 10, volatile.
dds_entity_t create_writer(dds_entity_t participant, const dds_topic_descriptor_t& descriptor,
                           const std::string& topic);

/// A reader of ROS 2 topic `topic` in the default partition with ROS 2's default QoS, keep-last `depth`
/// (live agents read their drivers' topics with it, docs/live.md).
dds_entity_t create_reader(dds_entity_t participant, const dds_topic_descriptor_t& descriptor,
                           const std::string& topic, int depth);

}  // namespace swarmloc::dds::ros2
