#pragma once
// The MURP range calibration as a JSON file (`swarmloc calibrate --murp … --out FILE`; docs/real-data.md
// "MURP range calibration"), in the schema of the team runtimes' range calibration
// (runtime/range_calibration_file.hpp, which the MURP replay reads) with the fit's diagnostics added:
//   {"model": "<how the figures are used>", "fitted_on": ["01", …],
//    "vehicles": {"1": {"lever_arms_m": [[x, y, z] × 6], "antenna_offsets_m": [6 numbers]}, "2": …, "3": …},
//    "coefficients_m": [5 numbers: RangeBias::Features order], "range_std_m", "spread_noise_gain",
//    "ranges_used", "outlier_fraction",
//    "spread_bins": [{"from_m", "to_m" (null: open), "ranges", "median_spread_m", "robust_std_m"}, …]}
// Only written here: runtime::read_range_calibration reads it back (the MURP replay, the UWB team agents),
// and it accepts the diagnostics as known keys.
#include <filesystem>
#include <string>

#include "swarmloc/world/murp_calibration.hpp"

namespace swarmloc::rundir {

/// The file's text (what write_murp_calibration writes).
std::string murp_calibration_json(const world::MurpRangeCalibration& calibration);

/// Writes the file; throws runtime::OutputError when it did not make it to disk.
void write_murp_calibration(const world::MurpRangeCalibration& calibration,
                            const std::filesystem::path& path);

}  // namespace swarmloc::rundir
