// The UWB team's IDL samples <-> plain types (uwb_team_wire.hpp) and the round trips of uwb_team_codec.hpp.
#include <string>

#include "convert_support.hpp"
#include "uwb_team_wire.hpp"

namespace swarmloc::dds {
namespace {

namespace uwb = estimators::uwb;
using uwb_codec::Problem;

swarmloc_uwb_Reading wire_reading(const std::optional<uwb::VehicleSensing>& sensing) {
  swarmloc_uwb_Reading wire{};
  if (!sensing) return wire;
  wire.roll_rad = sensing->tilt.roll_rad;
  wire.pitch_rad = sensing->tilt.pitch_rad;
  wire.turn_rad = sensing->turn_rad;
  wire.has_altitude = sensing->altitude_m.has_value();
  wire.altitude_m = sensing->altitude_m.value_or(0.0);
  return wire;
}

std::optional<uwb::VehicleSensing> reading_of(const swarmloc_uwb_Reading& wire, bool present) {
  if (!present) return std::nullopt;
  uwb::VehicleSensing sensing;
  sensing.tilt = {wire.roll_rad, wire.pitch_rad};
  sensing.turn_rad = wire.turn_rad;
  if (wire.has_altitude) sensing.altitude_m = wire.altitude_m;
  return sensing;
}

/// A matrix as its row-major entries (the IDL's layout; Eigen's default is column-major).
std::vector<double> row_major(const MatX& matrix) {
  std::vector<double> entries;
  entries.reserve(static_cast<std::size_t>(matrix.size()));
  for (Eigen::Index r = 0; r < matrix.rows(); ++r) {
    for (Eigen::Index c = 0; c < matrix.cols(); ++c) entries.push_back(matrix(r, c));
  }
  return entries;
}

MatX from_row_major(std::span<const double> entries, Eigen::Index rows, Eigen::Index cols) {
  MatX matrix(rows, cols);
  for (Eigen::Index r = 0; r < rows; ++r) {
    for (Eigen::Index c = 0; c < cols; ++c) matrix(r, c) = entries[static_cast<std::size_t>(r * cols + c)];
  }
  return matrix;
}

void require_range_bounds(const uwb::PeerRanges& ranges) {
  const auto rows = static_cast<std::size_t>(ranges.ranges_m.rows());
  const auto cols = static_cast<std::size_t>(ranges.ranges_m.cols());
  const bool spread_fits = ranges.spread_m.size() == 0 || (ranges.spread_m.rows() == ranges.ranges_m.rows() &&
                                                           ranges.spread_m.cols() == ranges.ranges_m.cols());
  if (rows > uwb_codec::kMaxAntennas || cols > uwb_codec::kMaxAntennas || !spread_fits) {
    throw DdsError("uwb window input: peer " + std::to_string(ranges.peer) + "'s ranges are " +
                   std::to_string(rows) + "x" + std::to_string(cols) +
                   " (at most 8x8, spread empty or alike)");
  }
}

}  // namespace

WireWindowInput::WireWindowInput(const UwbWindowInput& input) {
  if (input.ranges.size() > uwb_codec::kMaxTeam) throw DdsError("uwb window input: more than 8 peers");
  sample.vehicle = input.vehicle;
  sample.window = input.window;
  sample.time_s = input.time_s;
  sample.dt_s = input.dt_s;
  sample.stop = input.stop;
  sample.has_reading = input.sensing.has_value();
  sample.reading = wire_reading(input.sensing);
  ranges_m.reserve(input.ranges.size());
  spread_m.reserve(input.ranges.size());
  for (const auto& peer : input.ranges) {
    require_range_bounds(peer);
    ranges_m.push_back(row_major(peer.ranges_m));
    spread_m.push_back(row_major(peer.spread_m));
    swarmloc_uwb_PeerRangeWindow window{};
    window.peer = peer.peer;
    window.rows = static_cast<std::uint8_t>(peer.ranges_m.rows());
    window.cols = static_cast<std::uint8_t>(peer.ranges_m.cols());
    wire::point_at(window.ranges_m, ranges_m.back());
    wire::point_at(window.spread_m, spread_m.back());
    windows.push_back(window);
  }
  wire::point_at(sample.ranges, windows);
}

swarmloc_uwb_Sensing wire_sensing(const UwbSensing& sensing) {
  swarmloc_uwb_Sensing wire{};
  wire.vehicle = sensing.vehicle;
  wire.window = sensing.window;
  wire.present = sensing.sensing.has_value();
  wire.reading = wire_reading(sensing.sensing);
  return wire;
}

WireEstimates::WireEstimates(const UwbEstimates& estimates) {
  if (estimates.peers.size() > uwb_codec::kMaxTeam) throw DdsError("uwb estimates: more than 8 peers");
  sample.vehicle = estimates.vehicle;
  sample.window = estimates.window;
  sample.round = static_cast<std::uint8_t>(estimates.round);
  for (const auto& [peer, estimate] : estimates.peers) {
    swarmloc_uwb_PeerPose pose{};
    pose.peer = peer;
    const auto vector = estimate.pose.vector();
    for (int k = 0; k < 4; ++k) pose.pose[k] = vector(k);
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) pose.covariance[r * 4 + c] = estimate.covariance(r, c);
    }
    peers.push_back(pose);
  }
  wire::point_at(sample.peers, peers);
}

namespace uwb_codec {

Problem decode_range_window(std::int32_t peer, std::uint8_t rows, std::uint8_t cols,
                            std::span<const double> ranges, std::span<const double> spread,
                            uwb::PeerRanges& out) {
  if (rows == 0 || cols == 0 || rows > kMaxAntennas || cols > kMaxAntennas) return "range matrix size";
  const std::size_t entries = std::size_t{rows} * cols;
  if (ranges.size() != entries || (!spread.empty() && spread.size() != entries)) return "range matrix size";
  out.peer = peer;
  out.ranges_m = from_row_major(ranges, rows, cols);
  out.spread_m = spread.empty() ? MatX() : from_row_major(spread, rows, cols);
  return nullptr;
}

Problem decode_round(std::uint8_t wire, UwbRound& out) {
  if (wire > static_cast<std::uint8_t>(UwbRound::kFused)) return "unknown round";
  out = static_cast<UwbRound>(wire);
  return nullptr;
}

}  // namespace uwb_codec

Problem accept(const swarmloc_uwb_WindowInput& wire, const std::vector<AgentId>& team, UwbWindowInput& out) {
  out = UwbWindowInput{};
  out.vehicle = wire.vehicle;
  out.window = wire.window;
  out.time_s = wire.time_s;
  out.dt_s = wire.dt_s;
  out.stop = wire.stop;
  out.sensing = reading_of(wire.reading, wire.has_reading);
  const auto windows = wire::view(wire.ranges);
  if (!windows || windows->size() > uwb_codec::kMaxTeam) return "range windows";
  for (const auto& window : *windows) {
    const auto ranges = wire::view(window.ranges_m);
    const auto spread = wire::view(window.spread_m);
    if (!ranges || !spread) return "range matrix size";
    uwb::PeerRanges peer;
    if (const Problem problem =
            uwb_codec::decode_range_window(window.peer, window.rows, window.cols, *ranges, *spread, peer)) {
      return problem;
    }
    out.ranges.push_back(std::move(peer));
  }
  return uwb_codec::check_window_input(out, team);
}

Problem accept(const swarmloc_uwb_Sensing& wire, const std::vector<AgentId>& team, UwbSensing& out) {
  out = UwbSensing{wire.vehicle, wire.window, reading_of(wire.reading, wire.present)};
  return uwb_codec::check_sensing(out, team);
}

Problem accept(const swarmloc_uwb_Estimates& wire, const std::vector<AgentId>& team, UwbEstimates& out) {
  out = UwbEstimates{};
  out.vehicle = wire.vehicle;
  out.window = wire.window;
  if (const Problem problem = uwb_codec::decode_round(wire.round, out.round)) return problem;
  const auto peers = wire::view(wire.peers);
  if (!peers || peers->size() > uwb_codec::kMaxTeam) return "peer count";
  for (const auto& pose : *peers) {
    uwb::PoseEstimate estimate;
    estimate.pose =
        uwb::RelativePose::from(uwb::Vec4(pose.pose[0], pose.pose[1], pose.pose[2], pose.pose[3]));
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) estimate.covariance(r, c) = pose.covariance[r * 4 + c];
    }
    if (!out.peers.emplace(pose.peer, estimate).second) return "duplicate peer";
  }
  return uwb_codec::check_estimates(out, team);
}

namespace uwb_codec {

Received<UwbWindowInput> round_trip(const UwbWindowInput& input, const std::vector<AgentId>& team) {
  const WireWindowInput wire(input);
  UwbWindowInput back;
  const Problem problem = accept(wire.sample, team, back);
  return problem ? Received<UwbWindowInput>{std::nullopt, problem} : Received<UwbWindowInput>{back, nullptr};
}

Received<UwbSensing> round_trip(const UwbSensing& sensing, const std::vector<AgentId>& team) {
  UwbSensing back;
  const Problem problem = accept(wire_sensing(sensing), team, back);
  return problem ? Received<UwbSensing>{std::nullopt, problem} : Received<UwbSensing>{back, nullptr};
}

Received<UwbEstimates> round_trip(const UwbEstimates& estimates, const std::vector<AgentId>& team) {
  const WireEstimates wire(estimates);
  UwbEstimates back;
  const Problem problem = accept(wire.sample, team, back);
  return problem ? Received<UwbEstimates>{std::nullopt, problem} : Received<UwbEstimates>{back, nullptr};
}

}  // namespace uwb_codec
}  // namespace swarmloc::dds
