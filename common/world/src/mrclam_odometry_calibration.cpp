#include "mrclam_odometry_calibration.hpp"

#include <cmath>
#include <limits>

#include "swarmloc/models/measurement_models.hpp"

namespace swarmloc::world {
namespace detail {
namespace {

using GroundtruthPose = MrclamDataset::TimedPose;

/// True when the groundtruth rows from just before `from` to just after `to` are never more than
/// `max_gap_s` apart.
bool groundtruth_covers(const std::vector<GroundtruthPose>& track, double from, double to, double max_gap_s) {
  auto row = std::upper_bound(track.begin(), track.end(), from,
                              [](double time, const GroundtruthPose& pose) { return time < pose.time_s; });
  if (row != track.begin()) --row;  // the row at or before `from`
  const auto last =
      std::lower_bound(track.begin(), track.end(), to,
                       [](const GroundtruthPose& pose, double time) { return pose.time_s < time; });
  if (last == track.end()) return false;
  for (; row != last; ++row) {
    if (std::next(row)->time_s - row->time_s > max_gap_s) return false;
  }
  return true;
}

/// GroundtruthPose change over [from, to] in the start frame, integrating each row's (v, ω) as an exact
/// unicycle arc from its time to the next row's (the loader's rule).
GroundtruthPose integrate_odometry(const std::vector<MrclamDataset::OdometryRow>& rows, double from,
                                   double to) {
  GroundtruthPose p;
  auto row =
      std::upper_bound(rows.begin(), rows.end(), from,
                       [](double time, const MrclamDataset::OdometryRow& r) { return time < r.time_s; });
  if (row != rows.begin()) --row;
  for (; row != rows.end() && row->time_s < to; ++row) {
    const double begin = std::max(from, row->time_s);
    const double end = std::next(row) == rows.end() ? to : std::min(to, std::next(row)->time_s);
    const double dt = end - begin;
    if (dt <= 0.0) continue;
    const double turn = row->omega_radps * dt;
    const double distance = row->v_mps * dt;
    // Chord of the arc: length distance·sinc(turn/2), direction heading + turn/2.
    const double half = 0.5 * turn;
    const double chord = std::abs(half) < 1e-9 ? distance : distance * std::sin(half) / half;
    p.position_m += chord * Vec2(std::cos(p.heading_rad + half), std::sin(p.heading_rad + half));
    p.heading_rad += turn;
  }
  return p;
}

}  // namespace

WindowResiduals odometry_residuals(const MrclamDataset::Robot& robot, double window_s, double max_gap_s,
                                   double lag_s) {
  WindowResiduals out;
  if (robot.odometry.empty()) return out;
  const double first = robot.odometry.front().time_s;
  const double last = robot.odometry.back().time_s;
  for (double from = first; from + window_s <= last; from += window_s) {
    const double to = from + window_s;
    const auto start = groundtruth_at(robot.groundtruth, from, max_gap_s);
    const auto end = groundtruth_at(robot.groundtruth, to, max_gap_s);
    if (!start || !end || !groundtruth_covers(robot.groundtruth, from, to, max_gap_s)) {
      ++out.gaps;
      continue;
    }
    const GroundtruthPose odometry = integrate_odometry(robot.odometry, from - lag_s, to - lag_s);
    const Eigen::Rotation2Dd to_start_frame(-start->heading_rad);
    const Vec2 true_motion = to_start_frame * (end->position_m - start->position_m);
    const double true_turn = models::wrap_angle(end->heading_rad - start->heading_rad);
    // Along the odometry's chord direction (half its turn), so a heading error does not count as distance.
    const double half = 0.5 * odometry.heading_rad;
    const Vec2 along(std::cos(half), std::sin(half));
    const double odometry_distance = along.dot(odometry.position_m);
    const double true_distance = along.dot(true_motion);
    out.windows.push_back(
        {{true_distance - odometry_distance, models::wrap_angle(true_turn - odometry.heading_rad)},
         odometry_distance,
         true_distance});
  }
  return out;
}

OdometryCalibration calibrate_odometry(const WindowResiduals& residuals, double window_s, PairTrim trim) {
  OdometryCalibration out;
  out.window_s = window_s;
  out.skipped_gap = residuals.gaps;
  std::vector<Pair> pairs;
  pairs.reserve(residuals.windows.size());
  for (const auto& w : residuals.windows) pairs.push_back(w.residual);
  const auto stats = robust_pair_stats(pairs, trim);
  out.distance_m = stats[0];
  out.heading_rad = stats[1];
  double odometry_sum = 0.0;
  double true_sum = 0.0;
  for (const auto& w : residuals.windows) {
    const bool inlier = within_trim(w.residual, out.distance_m, out.heading_rad, trim);
    if (!inlier || std::abs(w.odometry_distance_m) < 0.01) continue;
    odometry_sum += w.odometry_distance_m;
    true_sum += w.true_distance_m;
  }
  out.distance_ratio = odometry_sum != 0.0 ? true_sum / odometry_sum : 1.0;
  return out;
}

OdometryLag measure_odometry_lag(const MrclamDataset& data, double max_gap_s, PairTrim trim) {
  OdometryLag out;
  double best = std::numeric_limits<double>::infinity();
  const int steps = static_cast<int>(std::lround(kMaxLagS / kLagStepS));
  for (int k = 0; k <= steps; ++k) {
    const double lag = k * kLagStepS;
    std::vector<Pair> pairs;
    for (const auto& robot : data.robots) {
      for (const auto& w : odometry_residuals(robot, kLagWindowS, max_gap_s, lag).windows) {
        pairs.push_back(w.residual);
      }
    }
    if (pairs.empty()) continue;
    const double heading_std = robust_pair_stats(pairs, trim)[1].std;
    out.curve.push_back({lag, heading_std});
    if (heading_std < best) {
      best = heading_std;
      out.lag_s = lag;
    }
  }
  return out;
}

}  // namespace detail

double OdometryCalibration::v_std() const {
  return window_s > 0.0 ? distance_m.std / std::sqrt(window_s) : 0.0;
}
double OdometryCalibration::omega_std() const {
  return window_s > 0.0 ? heading_rad.std / std::sqrt(window_s) : 0.0;
}

double OdometryCalibration::v_std_with_tails() const {
  return window_s > 0.0 ? distance_m.all_std / std::sqrt(window_s) : 0.0;
}
double OdometryCalibration::omega_std_with_tails() const {
  return window_s > 0.0 ? heading_rad.all_std / std::sqrt(window_s) : 0.0;
}

double OdometryCalibration::v_rms_with_tails() const {
  return window_s > 0.0 ? std::hypot(distance_m.all_std, distance_m.all_mean) / std::sqrt(window_s) : 0.0;
}
double OdometryCalibration::omega_rms_with_tails() const {
  return window_s > 0.0 ? std::hypot(heading_rad.all_std, heading_rad.all_mean) / std::sqrt(window_s) : 0.0;
}

}  // namespace swarmloc::world
