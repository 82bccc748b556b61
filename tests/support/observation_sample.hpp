#pragma once
// One OBSERVATIONS sample (team_pose_ekf) with every kind of content, for the wire and sample-log tests.
#include "swarmloc/estimators/messages.hpp"

namespace swarmloc::test {

/// A team_pose_ekf sample: a merged span with odometry and two sightings, and a span without odometry.
inline estimators::ObservationMessage observation_sample() {
  estimators::ObservationMessage m;
  m.origin_step = 9;
  m.origin_pose = Eigen::Vector3d(1.25, -3.5, 3.1);
  m.origin_covariance << 0.04, 0.001, -0.002, 0.001, 0.05, 0.003, -0.002, 0.003, 0.01;
  estimators::ObservedSteps merged;
  merged.first_world_step = 10, merged.world_step = 11, merged.world_time_s = 1.1;
  merged.odometry = estimators::OdometryInput{{{0.2, -0.1, 0.015}, {0.25, 0.05, 0.085}}, 0.011, 0.038};
  estimators::RangeBearingMeasurement landmark;
  landmark.landmark = true, landmark.landmark_m = Vec2(4.5, -1.0);
  landmark.landmark_cov << 1e-4, 2e-5, 2e-5, 3e-4;
  landmark.range_m = 2.25, landmark.bearing_rad = -0.5, landmark.range_std_m = 0.16,
  landmark.bearing_std_rad = 0.01;
  landmark.age_s = 0.035;
  estimators::RangeBearingMeasurement robot;
  robot.peer = 4, robot.range_m = 1.5, robot.bearing_rad = 3.0, robot.range_std_m = 0.1,
  robot.bearing_std_rad = 0.02;
  merged.range_bearings = {landmark, robot};
  estimators::ObservedSteps still;
  still.first_world_step = still.world_step = 12, still.world_time_s = 1.2;
  m.spans = {merged, still};
  return m;
}

}  // namespace swarmloc::test
