#pragma once
// `swarmloc calibrate --mrclam DIR`: measures a UTIAS MRCLAM dataset's range, bearing and odometry noise
// against its own groundtruth (world::calibrate_mrclam), prints the figures with how each was measured,
// and writes them as a scenario fragment (docs/real-data.md, "Noise model").
#include <string>

namespace swarmloc::orchestrator {

struct CalibrateOptions {
  std::string mrclam_dir;
  std::string out_path;  ///< the YAML fragment; empty: none written
};

/// Returns the process exit code (0 ok; 2 bad input: missing or unreadable dataset, no usable samples,
/// unwritable --out).
int run_calibrate(const CalibrateOptions& options);

}  // namespace swarmloc::orchestrator
