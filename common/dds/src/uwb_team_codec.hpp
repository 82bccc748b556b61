#pragma once
// The IDL-free face of the UWB team's samples (idl/uwb_team.idl, uwb_team_io.hpp): what a received sample
// must satisfy to be used, and round trips through the IDL structs for the unit tests, which cannot include
// the generated header (swarmloc_idl is linked privately into swarmloc_dds).
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "swarmloc/dds/uwb_team_io.hpp"

namespace swarmloc::dds::uwb_codec {

// Bounds of idl/uwb_team.idl.
inline constexpr std::size_t kMaxTeam = 8;
inline constexpr std::size_t kMaxAntennas = 8;
inline constexpr std::size_t kMaxAntennaPairs = 64;
/// Larger ranges, positions and altitudes are absurd for a team that ranges over UWB.
inline constexpr double kMaxDistanceM = 1e4;
/// Angles (tilt, turn, heading) beyond this many radians are absurd: a reading wraps within ±π.
inline constexpr double kMaxAngleRad = 8.0;

/// Why a received sample is refused: a short static text that names the rule, or nullptr (accepted).
using Problem = const char*;

/// A range window's wire fields (row-major rows x cols; spread empty or the same size) into `out`.
Problem decode_range_window(std::int32_t peer, std::uint8_t rows, std::uint8_t cols,
                            std::span<const double> ranges, std::span<const double> spread,
                            estimators::uwb::PeerRanges& out);
/// An Estimates sample's round byte.
Problem decode_round(std::uint8_t wire, UwbRound& out);

/// The rules of each sample once decoded. `team` is the roster every vehicle id must be in. Ranges may be
/// NaN (no reading) and spreads NaN (unknown); every other number must be finite and within the bounds
/// above; a covariance must be symmetric with a non-negative diagonal; a peer appears at most once and is
/// never the sender (or the receiving vehicle, in a window input).
Problem check_window_input(const UwbWindowInput& input, const std::vector<AgentId>& team);
Problem check_sensing(const UwbSensing& sensing, const std::vector<AgentId>& team);
Problem check_estimates(const UwbEstimates& estimates, const std::vector<AgentId>& team);
Problem check_vehicle_sensing(const estimators::uwb::VehicleSensing& sensing);
Problem check_pose_estimate(const estimators::uwb::PoseEstimate& estimate);

/// A sample after encoding to the IDL struct, decoding and checking: the value, or why it was refused.
template <typename Sample>
struct Received {
  std::optional<Sample> value;
  Problem problem = nullptr;
};

// Round trips through the exact code that dds_write / dds_take use. Encoding throws DdsError for a sample
// beyond the IDL's bounds.
Received<UwbWindowInput> round_trip(const UwbWindowInput& input, const std::vector<AgentId>& team);
Received<UwbSensing> round_trip(const UwbSensing& sensing, const std::vector<AgentId>& team);
Received<UwbEstimates> round_trip(const UwbEstimates& estimates, const std::vector<AgentId>& team);

}  // namespace swarmloc::dds::uwb_codec
