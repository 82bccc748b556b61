#pragma once
// The UWB range calibration file (`swarmloc calibrate --murp --out`, docs/real-data.md, "MURP") that the team
// runtimes read: JSON with each vehicle's antenna lever arms and range offsets, the geometric bias
// coefficients and the noise model. The calibration of the MURP dataset fitted on its trials 01–12
// (scenarios/murp-range-bias.json) is built into the binaries.
#include <filesystem>
#include <string>
#include <string_view>

#include "swarmloc/estimators/uwb/range_calibration.hpp"

namespace swarmloc::runtime {

/// Parses and validates a calibration; `source` names it in errors. Throws config::ScenarioError naming the
/// field for text that is not JSON, a missing or mistyped field, a non-finite number, a non-positive
/// range_std_m, a negative spread_noise_gain, a vehicle whose offsets do not match its antennas, or no
/// vehicle.
estimators::uwb::RangeCalibration parse_range_calibration(std::string_view text, const std::string& source);

/// parse_range_calibration of a file's contents (ScenarioError also for an unreadable file).
estimators::uwb::RangeCalibration read_range_calibration(const std::filesystem::path& path);

/// The file's text; `model` describes how it was fitted (kept as the "model" field).
std::string range_calibration_json(const estimators::uwb::RangeCalibration& calibration,
                                   const std::string& model);

/// The built-in MURP calibration (throws ScenarioError if this build has none).
estimators::uwb::RangeCalibration builtin_murp_calibration();

}  // namespace swarmloc::runtime
