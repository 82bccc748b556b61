#pragma once
// The MURP range calibration as a JSON file (`swarmloc calibrate --murp … --out FILE`, read by the MURP
// replay; docs/real-data.md "MURP range calibration"):
//   {"model": "<how the figures are used>", "fitted_on": ["01", …],
//    "antenna_offsets_m": [[6 numbers: vehicle 1], [vehicle 2], [vehicle 3]],
//    "coefficients_m": {"abs_sin_elevation", "sin_elevation_sq", "sin_elevation", "facing_sum",
//                       "facing_sq_sum"},
//    "range_std_m", "spread_noise_gain", "ranges_used", "outlier_fraction",
//    "spread_bins": [{"from_m", "to_m" (null: open), "ranges", "median_spread_m", "robust_std_m"}, …]}
#include <filesystem>
#include <string>

#include "swarmloc/world/murp_calibration.hpp"

namespace swarmloc::rundir {

/// The file's text (what write_murp_calibration writes).
std::string murp_calibration_json(const world::MurpRangeCalibration& calibration);

/// Writes the file; throws runtime::OutputError when it did not make it to disk.
void write_murp_calibration(const world::MurpRangeCalibration& calibration,
                            const std::filesystem::path& path);

/// Reads and validates a file: every field present with its type, numbers finite, 3 vehicles of 6 offsets,
/// range_std_m > 0, spread_noise_gain >= 0, outlier_fraction in [0, 1], no unknown key. Throws
/// config::ScenarioError naming the file and the field.
world::MurpRangeCalibration read_murp_calibration(const std::filesystem::path& path);

/// The same from text; `source` names it in the errors.
world::MurpRangeCalibration parse_murp_calibration(const std::string& text, const std::string& source);

}  // namespace swarmloc::rundir
