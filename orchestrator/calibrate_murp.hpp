#pragma once
// `swarmloc calibrate --murp DIR [DIR ...] --out FILE.json`: fits the MURP UWB dataset's range model
// (per-antenna offsets, the line of sight's bias, the noise and its growth with the readings' spread) to the
// trials' motion-capture truth (world::calibrate_murp_ranges), prints it and writes it as JSON
// (rundir/murp_calibration_file.hpp; docs/real-data.md "MURP range calibration").
#include <string>
#include <vector>

#include "swarmloc/world/murp_calibration.hpp"

namespace swarmloc::orchestrator {

/// The range model fitted to the trials in `dirs` (each a parsed/NN directory). Throws config::ScenarioError
/// for an unreadable trial or too few ranges.
world::MurpRangeCalibration measure_murp_ranges(const std::vector<std::string>& dirs);

/// The table `calibrate --murp` prints.
std::string murp_calibration_report(const world::MurpRangeCalibration& calibration);

/// Returns the process exit code (0 ok; 2 bad input: an unreadable trial, too few ranges, unwritable --out).
int run_calibrate_murp(const std::vector<std::string>& dirs, const std::string& out_path);

}  // namespace swarmloc::orchestrator
