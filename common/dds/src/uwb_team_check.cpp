// What a received UWB team sample must satisfy to be used (uwb_team_codec.hpp): a hostile or broken writer's
// sample is refused with the rule it broke, and never reaches a filter.
#include <algorithm>
#include <cmath>
#include <set>
#include <span>

#include "uwb_team_codec.hpp"

namespace swarmloc::dds::uwb_codec {
namespace {

namespace uwb = estimators::uwb;

bool on_team(AgentId vehicle, const std::vector<AgentId>& team) {
  return std::find(team.begin(), team.end(), vehicle) != team.end();
}

bool finite_within(double value, double bound) { return std::isfinite(value) && std::abs(value) <= bound; }

/// NaN (no reading, unknown) or a finite value in [low, kMaxDistanceM].
bool missing_or_within(double value, double low) {
  return std::isnan(value) || (std::isfinite(value) && value >= low && value <= kMaxDistanceM);
}

Problem check_ranges(const uwb::PeerRanges& ranges) {
  const MatX& r = ranges.ranges_m;
  if (r.size() == 0 || r.rows() > static_cast<Eigen::Index>(kMaxAntennas) ||
      r.cols() > static_cast<Eigen::Index>(kMaxAntennas)) {
    return "range matrix size";
  }
  const MatX& s = ranges.spread_m;
  if (s.size() != 0 && (s.rows() != r.rows() || s.cols() != r.cols())) return "range matrix size";
  // A range is a distance: zero or negative is no reading (the loader makes those NaN).
  const auto entries = [](const MatX& m) {
    return std::span<const double>(m.data(), static_cast<std::size_t>(m.size()));
  };
  if (!std::ranges::all_of(entries(r), [](double v) { return missing_or_within(v, 1e-9); })) {
    return "range out of bounds";
  }
  if (!std::ranges::all_of(entries(s), [](double v) { return missing_or_within(v, 0.0); })) {
    return "spread out of bounds";
  }
  return nullptr;
}

/// Window and time fields: a window index from 0 on (−1 only for a hello), finite times.
bool window_index_ok(std::int64_t window, bool hello) { return hello ? window == -1 : window >= 0; }

}  // namespace

Problem check_vehicle_sensing(const uwb::VehicleSensing& sensing) {
  if (!finite_within(sensing.tilt.roll_rad, kMaxAngleRad) ||
      !finite_within(sensing.tilt.pitch_rad, kMaxAngleRad) ||
      !finite_within(sensing.turn_rad, kMaxAngleRad)) {
    return "non-finite or absurd reading";
  }
  if (sensing.altitude_m && !finite_within(*sensing.altitude_m, kMaxDistanceM))
    return "non-finite or absurd reading";
  return nullptr;
}

Problem check_pose_estimate(const uwb::PoseEstimate& estimate) {
  const auto& p = estimate.pose.position_m;
  if (!finite_within(p.x(), kMaxDistanceM) || !finite_within(p.y(), kMaxDistanceM) ||
      !finite_within(p.z(), kMaxDistanceM) || !std::isfinite(estimate.pose.heading_rad)) {
    return "non-finite or absurd pose";
  }
  const uwb::Mat4& c = estimate.covariance;
  if (!c.allFinite()) return "non-finite covariance";
  // The filter's covariances come out of an inverse: symmetric to rounding, not bit for bit.
  const double scale = std::max(1.0, c.cwiseAbs().maxCoeff());
  if ((c - c.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale) return "non-symmetric covariance";
  if ((c.diagonal().array() < 0.0).any()) return "negative variance";
  return nullptr;
}

Problem check_window_input(const UwbWindowInput& input, const std::vector<AgentId>& team) {
  if (!on_team(input.vehicle, team)) return "unknown vehicle";
  if (input.stop) return input.sensing || !input.ranges.empty() ? "stop with data" : nullptr;
  if (!window_index_ok(input.window, false) || !std::isfinite(input.time_s) || !std::isfinite(input.dt_s) ||
      input.dt_s < 0.0) {
    return "bad window or time";
  }
  if (input.sensing) {
    if (const Problem problem = check_vehicle_sensing(*input.sensing)) return problem;
  }
  std::set<AgentId> peers;
  for (const auto& ranges : input.ranges) {
    if (!on_team(ranges.peer, team) || ranges.peer == input.vehicle) return "unknown peer";
    if (!peers.insert(ranges.peer).second) return "duplicate peer";
    if (const Problem problem = check_ranges(ranges)) return problem;
  }
  return nullptr;
}

Problem check_sensing(const UwbSensing& sensing, const std::vector<AgentId>& team) {
  if (!on_team(sensing.vehicle, team)) return "unknown vehicle";
  if (!window_index_ok(sensing.window, false)) return "bad window or time";
  return sensing.sensing ? check_vehicle_sensing(*sensing.sensing) : nullptr;
}

Problem check_estimates(const UwbEstimates& estimates, const std::vector<AgentId>& team) {
  if (!on_team(estimates.vehicle, team)) return "unknown vehicle";
  const bool hello = estimates.round == UwbRound::kHello;
  if (!window_index_ok(estimates.window, hello)) return "bad window or time";
  if (hello && !estimates.peers.empty()) return "hello with estimates";
  for (const auto& [peer, estimate] : estimates.peers) {
    if (!on_team(peer, team) || peer == estimates.vehicle) return "unknown peer";
    if (const Problem problem = check_pose_estimate(estimate)) return problem;
  }
  return nullptr;
}

}  // namespace swarmloc::dds::uwb_codec
