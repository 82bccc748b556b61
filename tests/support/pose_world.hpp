#pragma once
// A simulated team of unicycle robots with odometry and range-bearing sightings of landmarks and of each
// other (the pose-state filters' tests). The test owns the RNG: a seed gives the same world every time.
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/pose/kernels.hpp"
#include "swarmloc/models/measurement_models.hpp"

namespace swarmloc::estimators::pose_world {

struct WorldConfig {
  int robots = 4;
  std::vector<Vec2> landmarks;
  int steps = 1000;
  double step_s = 0.2;
  int segments_per_step = 2;
  double v_std = 0.05;      ///< m/√s
  double omega_std = 0.05;  ///< rad/√s
  double range_std_m = 0.1;
  double bearing_std_rad = 0.03;
  double landmark_radius_m = 5.0;  ///< landmarks seen within this distance
  double robot_radius_m = 5.0;     ///< robots seen within this distance (0: never)
  double initial_std_m = 0.2;
  double initial_heading_std_rad = 0.05;
  unsigned seed = 1;
};

struct World {
  std::vector<AgentSetup> setups;                      ///< priors drawn around the truth
  std::vector<std::vector<Pose>> truth;                ///< [step][robot], after the step's motion
  std::vector<std::vector<MeasurementBatch>> batches;  ///< [step][robot]
};

inline World simulate(const WorldConfig& c) {
  std::mt19937 rng(c.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const auto n = static_cast<std::size_t>(c.robots);
  World world;
  std::vector<Pose> pose(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double angle = 2.0 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(n);
    pose[i] =
        Pose(2.5 * std::cos(angle), 2.5 * std::sin(angle), models::wrap_angle(angle + std::numbers::pi / 2));
    AgentSetup setup;
    setup.id = static_cast<AgentId>(i);
    setup.initial_guess_m = pose[i].head<2>() + c.initial_std_m * Vec2(normal(rng), normal(rng));
    setup.initial_heading_rad = pose[i].z() + c.initial_heading_std_rad * normal(rng);
    world.setups.push_back(setup);
  }
  const double dt = c.step_s / c.segments_per_step;
  for (int k = 0; k < c.steps; ++k) {
    std::vector<MeasurementBatch> batches(n);
    for (std::size_t i = 0; i < n; ++i) {
      MeasurementBatch& batch = batches[i];
      batch.world_step = k;
      batch.world_time_s = (k + 1) * c.step_s;
      OdometryInput odometry;
      odometry.v_std = c.v_std;
      odometry.omega_std = c.omega_std;
      for (int s = 0; s < c.segments_per_step; ++s) {
        const double t = batch.world_time_s + s * dt;
        const double v = 0.25 + 0.1 * std::sin(0.05 * t + static_cast<double>(i));
        double omega = 0.3 * std::sin(0.11 * t + 2.0 * static_cast<double>(i));
        const Vec2 p = pose[i].head<2>();
        if (p.norm() > 3.5) {  // steer back toward the arena centre
          omega += 1.0 * models::wrap_angle(std::atan2(-p.y(), -p.x()) - pose[i].z());
        }
        pose[i] = models::unicycle_step(pose[i], v * dt, omega * dt).pose;
        // Reported inputs: white noise with densities v_std, omega_std (distance variance v_std²·dt).
        odometry.segments.push_back(OdometrySegment{v + c.v_std / std::sqrt(dt) * normal(rng),
                                                    omega + c.omega_std / std::sqrt(dt) * normal(rng), dt});
      }
      batch.odometry = odometry;
    }
    for (std::size_t i = 0; i < n; ++i) {
      MeasurementBatch& batch = batches[i];
      const auto measure = [&](const Vec2& target, RangeBearingMeasurement m) {
        const auto h = models::range_bearing(pose[i], target);
        m.range_m = h->value.x() + c.range_std_m * normal(rng);
        m.bearing_rad = models::wrap_angle(h->value.y() + c.bearing_std_rad * normal(rng));
        m.range_std_m = c.range_std_m;
        m.bearing_std_rad = c.bearing_std_rad;
        batch.range_bearings.push_back(m);
      };
      for (const Vec2& landmark : c.landmarks) {
        if ((landmark - pose[i].head<2>()).norm() > c.landmark_radius_m) continue;
        RangeBearingMeasurement m;
        m.landmark = true;
        m.landmark_m = landmark;
        measure(landmark, m);
      }
      for (std::size_t j = 0; j < n; ++j) {
        if (j == i || (pose[j].head<2>() - pose[i].head<2>()).norm() > c.robot_radius_m) continue;
        batch.neighbours.push_back(static_cast<AgentId>(j));
        RangeBearingMeasurement m;
        m.peer = static_cast<AgentId>(j);
        measure(pose[j].head<2>(), m);
      }
    }
    world.truth.push_back(pose);
    world.batches.push_back(std::move(batches));
  }
  return world;
}

inline KalmanFilterParams params_for(const WorldConfig& c) {
  KalmanFilterParams params;
  params.initial_std_m = c.initial_std_m;
  params.initial_heading_std_rad = c.initial_heading_std_rad;
  params.process_noise_std_m = 0.05;  // unknown motion of a peer over one step (~v·dt)
  return params;
}

}  // namespace swarmloc::estimators::pose_world
