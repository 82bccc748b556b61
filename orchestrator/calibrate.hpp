#pragma once
// `swarmloc calibrate --mrclam DIR`: measures a UTIAS MRCLAM dataset's range, bearing and odometry noise
// against its own groundtruth (world::calibrate_mrclam), prints the figures with how each was measured,
// and writes them as a scenario fragment (docs/real-data.md, "Noise model"). `--murp DIR...` fits the MURP
// UWB dataset's range model instead (calibrate_murp.hpp).
#include <string>
#include <vector>

#include "swarmloc/world/mrclam_calibration.hpp"

namespace swarmloc::orchestrator {

struct CalibrateOptions {
  std::string mrclam_dir;
  std::vector<std::string> murp_dirs;  ///< MURP trial directories (parsed/NN); exclusive with mrclam_dir
  std::string out_path;                ///< the YAML fragment (--mrclam), the JSON file (--murp); empty: none
};

/// The noise model of the MRCLAM dataset in `dir`, measured against its own groundtruth. Throws
/// config::ScenarioError when it has too few usable samples to measure one (and whatever load_mrclam throws
/// for an unreadable dataset).
world::MrclamCalibration measure_mrclam_noise(const std::string& dir);

/// The pooled model as a scenario fragment: comment lines saying how it was measured, then a `noise:`
/// block. What `calibrate --out` writes and `replay --mrclam` uses.
std::string noise_fragment(const std::string& dir, const world::MrclamCalibration& calibration);

/// Returns the process exit code (0 ok; 2 bad input: missing or unreadable dataset, no usable samples,
/// unwritable --out). With murp_dirs, run_calibrate_murp's.
int run_calibrate(const CalibrateOptions& options);

}  // namespace swarmloc::orchestrator
