#pragma once
// Where the tests find the real datasets, which are never part of the project: $SWARMLOC_MRCLAM_DIR, or
// shared/data/utias-mrclam/MRCLAM_Dataset6 beside the checkout or beside any of its parent directories
// (a clone in /work/<x>/<y> finds /work/shared/data). Empty if none exists: the test skips and says so.
// The same for the MIT MURP UWB dataset ($SWARMLOC_MURP_DIR, shared/data/mit-murp-uwb/parsed).
// And the scenario that runs pose_ekf on an MRCLAM dataset directory.
#include <cstdlib>
#include <filesystem>
#include <string>

#include "swarmloc/config/scenario.hpp"

namespace swarmloc::testing {

/// `relative` in shared/data beside the checkout or beside any of its parent directories, if it holds
/// `marker` (or `marker`.gz); empty if none does.
inline std::filesystem::path shared_dataset(const std::filesystem::path& source_dir,
                                            const std::filesystem::path& relative,
                                            const std::string& marker) {
  std::error_code error;
  auto dir = std::filesystem::weakly_canonical(source_dir, error);
  if (error) dir = source_dir;
  for (; !dir.empty(); dir = dir.parent_path()) {
    const auto candidate = dir.parent_path() / "shared" / "data" / relative;
    if (std::filesystem::exists(candidate / (marker + ".gz")) ||
        std::filesystem::exists(candidate / marker)) {
      return candidate;
    }
    if (dir == dir.parent_path()) break;
  }
  return {};
}

inline std::filesystem::path mrclam_dataset6(const std::filesystem::path& source_dir) {
  if (const char* dir = std::getenv("SWARMLOC_MRCLAM_DIR")) return dir;
  return shared_dataset(source_dir, "utias-mrclam/MRCLAM_Dataset6", "Barcodes.dat");
}

/// The MIT MURP UWB dataset's parsed/ directory (one folder per trial, 01-17): $SWARMLOC_MURP_DIR, or
/// shared/data/mit-murp-uwb/parsed found as MRCLAM's is.
inline std::filesystem::path murp_parsed(const std::filesystem::path& source_dir) {
  if (const char* dir = std::getenv("SWARMLOC_MURP_DIR")) return dir;
  return shared_dataset(source_dir, "mit-murp-uwb/parsed", "13/13_base-1_targ-2_win-1_step-1.csv");
}

/// pose_ekf on the five robots of the MRCLAM dataset in `dir`, for `steps` world steps (validated).
inline config::Scenario mrclam_scenario(const std::filesystem::path& dir, int steps) {
  config::Scenario s;
  s.algorithm.name = "pose_ekf";
  s.world.source = config::WorldSource::kMrclam;
  s.world.data_dir = dir.string();
  s.world.agents = 5;
  s.world.anchors = 0;
  s.run.steps = steps;
  config::validate(s);
  return s;
}

}  // namespace swarmloc::testing
