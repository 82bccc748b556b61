#pragma once
// The UWB range calibration file (`swarmloc calibrate --murp --out`, docs/real-data.md, "MURP") that the team
// runtimes read: JSON with each vehicle's antenna lever arms and range offsets, the geometric bias
// coefficients and the noise model. The calibration of the MURP dataset fitted on its trials 01–12
// (scenarios/murp-range-bias.json) is built into the binaries. This is the file's only reader; it is
// written by range_calibration_json (a run's range_model.json) and by the run directory library's
// write_murp_calibration (the fit, with its diagnostics added: rundir/murp_calibration_file.hpp):
//   {"model": "<how the figures are used>", "fitted_on": ["01", …],
//    "vehicles": {"1": {"lever_arms_m": [[x, y, z], …], "antenna_offsets_m": [one per lever arm]}, …},
//    "coefficients_m": [5 numbers: RangeBias::Features order], "range_std_m", "spread_noise_gain",
//    "ranges_used", "outlier_fraction",
//    "spread_bins": [{"from_m", "to_m" (null: open), "ranges", "median_spread_m", "robust_std_m"}, …]}
// vehicles, coefficients_m, range_std_m and spread_noise_gain are required; the rest is optional.
#include <filesystem>
#include <string>
#include <string_view>

#include "swarmloc/estimators/uwb/range_calibration.hpp"

namespace swarmloc::runtime {

/// Parses and validates a calibration; `source` names it in errors. Throws config::ScenarioError naming the
/// field for text that is not a JSON object, a key the format does not have (at the top level, in a vehicle
/// or in a spread bin), a missing or mistyped field, a non-finite number, a non-positive range_std_m, a
/// negative spread_noise_gain, a vehicle whose offsets do not match its antennas, or no vehicle. The
/// description and diagnostics (model, fitted_on, ranges_used, outlier_fraction in [0, 1], spread_bins) are
/// type-checked when present; only fitted_on is kept.
estimators::uwb::RangeCalibration parse_range_calibration(std::string_view text, const std::string& source);

/// parse_range_calibration of a file's contents (ScenarioError also for an unreadable file).
estimators::uwb::RangeCalibration read_range_calibration(const std::filesystem::path& path);

/// The file's text; `model` describes how it was fitted (kept as the "model" field).
std::string range_calibration_json(const estimators::uwb::RangeCalibration& calibration,
                                   const std::string& model);

/// The built-in MURP calibration (throws ScenarioError if this build has none).
estimators::uwb::RangeCalibration builtin_murp_calibration();

}  // namespace swarmloc::runtime
