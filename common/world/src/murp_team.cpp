#include "swarmloc/world/murp_team.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace swarmloc::world {
namespace {

namespace uwb = estimators::uwb;

/// A pose's attitude as an IMU reports it: yaw, pitch, roll with R = Rz(yaw)·Ry(pitch)·Rx(roll).
struct ImuAttitude {
  double yaw_rad = 0.0;
  uwb::Tilt tilt;
};

ImuAttitude imu_attitude(const MurpPose& pose) {
  const Mat3 r = murp_rotation(pose);
  return {std::atan2(r(1, 0), r(0, 0)),
          {std::atan2(r(2, 1), r(2, 2)), -std::asin(std::clamp(r(2, 0), -1.0, 1.0))}};
}

uwb::RelativePose relative_truth(const MurpPose& base, const MurpPose& target) {
  const double base_yaw = imu_attitude(base).yaw_rad;
  return {uwb::yaw_rotation(-base_yaw) * (target.position_m - base.position_m),
          std::remainder(imu_attitude(target).yaw_rad - base_yaw, 2.0 * std::numbers::pi)};
}

/// Every vehicle's pose in every window time, from the first file that has it.
std::map<double, std::map<AgentId, MurpPose>> poses_by_time(const MurpTrial& trial) {
  std::map<double, std::map<AgentId, MurpPose>> poses;
  for (const auto& pair : trial.pairs) {
    for (const auto& window : pair.windows) {
      auto& at = poses[window.time_s];
      at.emplace(pair.base, window.base);
      at.emplace(pair.target, window.target);
    }
  }
  return poses;
}

}  // namespace

std::vector<MurpTeamWindow> murp_team_windows(const MurpTrial& trial) {
  const auto poses = poses_by_time(trial);
  std::map<double, MurpTeamWindow> by_time;
  for (const auto& pair : trial.pairs) {
    for (const auto& window : pair.windows) {
      auto& team = by_time[window.time_s];
      team.ranges[pair.base].push_back({pair.target, window.ranges_m, window.range_std_m});
      team.truth[{pair.base, pair.target}] = relative_truth(window.base, window.target);
    }
  }
  std::vector<MurpTeamWindow> windows;
  const std::map<AgentId, MurpPose>* previous = nullptr;
  double previous_time = 0.0;
  for (auto& [time, team] : by_time) {
    team.index = static_cast<std::int64_t>(windows.size());
    team.time_s = time;
    team.dt_s = previous != nullptr ? time - previous_time : 0.0;
    const auto& now = poses.at(time);
    for (const auto& [vehicle, pose] : now) {
      const ImuAttitude attitude = imu_attitude(pose);
      uwb::VehicleSensing sensing{attitude.tilt, 0.0, pose.position_m.z()};
      if (previous != nullptr && previous->contains(vehicle)) {
        sensing.turn_rad = std::remainder(attitude.yaw_rad - imu_attitude(previous->at(vehicle)).yaw_rad,
                                          2.0 * std::numbers::pi);
      }
      team.sensing[vehicle] = sensing;
    }
    previous = &now;
    previous_time = time;
    windows.push_back(std::move(team));
  }
  return windows;
}

std::pair<double, double> relative_errors(const uwb::RelativePose& estimate, const uwb::RelativePose& truth) {
  return {(estimate.position_m - truth.position_m).norm(),
          std::abs(std::remainder(estimate.heading_rad - truth.heading_rad, 2.0 * std::numbers::pi))};
}

void RelativeErrorStats::add(const uwb::RelativePose& estimate, const uwb::RelativePose& truth) {
  const auto [position, heading] = relative_errors(estimate, truth);
  const double distance = truth.position_m.norm();
  ++windows;
  position_abs_sum_m += position;
  position_sq_sum_m2 += position * position;
  heading_abs_sum_deg += heading * 180.0 / std::numbers::pi;
  range_normalized_sum += distance > 0.0 ? position / distance : 0.0;
  distance_sum_m += distance;
}

void RelativeErrorStats::add(const RelativeErrorStats& other) {
  windows += other.windows;
  position_abs_sum_m += other.position_abs_sum_m;
  position_sq_sum_m2 += other.position_sq_sum_m2;
  heading_abs_sum_deg += other.heading_abs_sum_deg;
  range_normalized_sum += other.range_normalized_sum;
  distance_sum_m += other.distance_sum_m;
}

namespace {
double mean(double sum, std::int64_t count) {
  return count > 0 ? sum / static_cast<double>(count) : std::nan("");
}
}  // namespace

double RelativeErrorStats::position_mae_m() const { return mean(position_abs_sum_m, windows); }
double RelativeErrorStats::position_rmse_m() const { return std::sqrt(mean(position_sq_sum_m2, windows)); }
double RelativeErrorStats::heading_mae_deg() const { return mean(heading_abs_sum_deg, windows); }
double RelativeErrorStats::range_normalized_mae() const { return mean(range_normalized_sum, windows); }
double RelativeErrorStats::mean_distance_m() const { return mean(distance_sum_m, windows); }

MurpScore score_murp(const std::vector<MurpTeamWindow>& windows,
                     const std::vector<RelativeEstimateRow>& rows) {
  MurpScore score;
  std::map<std::pair<std::int64_t, std::pair<AgentId, AgentId>>, bool> estimated;
  for (const auto& row : rows) {
    const auto pair = std::make_pair(row.base, row.target);
    if (row.window < 0 || row.window >= static_cast<std::int64_t>(windows.size())) {
      ++score.unscored_rows;
      continue;
    }
    const auto& truth = windows[static_cast<std::size_t>(row.window)].truth;
    const auto found = truth.find(pair);
    if (found == truth.end()) {
      ++score.unscored_rows;
      continue;
    }
    score.per_pair[pair].add(row.estimate.pose, found->second);
    estimated[{row.window, pair}] = true;
  }
  for (const auto& window : windows) {
    for (const auto& [pair, truth] : window.truth) {
      if (!estimated.contains({window.index, pair})) ++score.missing_estimates;
    }
  }
  for (const auto& [pair, stats] : score.per_pair) score.pooled.add(stats);
  return score;
}

}  // namespace swarmloc::world
