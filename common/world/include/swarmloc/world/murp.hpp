#pragma once
// MIT ACL MURP multi-agent UWB dataset (Fishberg, Quiter, How, RA-L 2024; docs/real-data.md §MURP): three
// vehicles with six UWB antennas each, one file per ordered pair (base A, target B) and trial, one row per
// 1-s window: the 36 antenna-pair ranges averaged over the window, and both vehicles' motion-capture poses.
// The data is read from the user's directory (plain .csv or gzip-compressed .csv.gz), never shipped.
#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "swarmloc/core/types.hpp"

namespace swarmloc::world {

inline constexpr int kMurpVehicles = 3;
inline constexpr int kMurpAntennas = 6;

/// A vehicle's pose: position (m) and roll, pitch, yaw (rad), rotation R = Rz(yaw)·Ry(pitch)·Rx(roll).
struct MurpPose {
  Vec3 position_m = Vec3::Zero();
  double roll_rad = 0.0;
  double pitch_rad = 0.0;
  double yaw_rad = 0.0;
};

/// One window of one ordered pair: ranges_m(i, j) is the mean range from antenna i of the base to antenna j
/// of the target (0-based); NaN where the window has no valid reading of that antenna pair.
struct MurpWindow {
  double time_s = 0.0;  ///< window start, seconds since the trial's start
  MurpPose base;        ///< motion-capture pose of the base over the window
  MurpPose target;
  Eigen::Matrix<double, kMurpAntennas, kMurpAntennas> ranges_m;
  Eigen::Matrix<double, kMurpAntennas, kMurpAntennas> range_std_m;  ///< std of the readings averaged
  [[nodiscard]] int valid_ranges() const;
};

/// The windows of one ordered pair (vehicles numbered 1–3 as in the file names).
struct MurpPairLog {
  int base = 0;
  int target = 0;
  std::filesystem::path file;
  std::vector<MurpWindow> windows;
  int skipped_windows = 0;  ///< rows dropped: fewer than kMurpMinValidRanges valid ranges, or no pose
};

/// Windows with fewer valid ranges than this carry too little to place a vehicle (three position
/// coordinates and a heading) and are skipped and counted.
inline constexpr int kMurpMinValidRanges = 4;

struct MurpTrial {
  std::string name;  ///< the trial number as in the file names ("13")
  std::filesystem::path directory;
  std::vector<MurpPairLog> pairs;  ///< all six ordered pairs, (1,2), (1,3), (2,1), (2,3), (3,1), (3,2)
  [[nodiscard]] const MurpPairLog& pair(int base, int target) const;
};

/// Reads the six files NN_base-A_targ-B_win-1_step-1.csv[.gz] of `directory` (NN found from the files).
/// Throws config::ScenarioError naming the file (and line) for a missing pair, a file that is not readable
/// text or gzip, a header without the expected columns, a truncated or unparsable row, or non-finite poses.
/// Non-finite or non-positive ranges become NaN (not used); a row with fewer than kMurpMinValidRanges
/// valid ranges is skipped and counted.
MurpTrial load_murp_trial(const std::filesystem::path& directory);

/// Rotation of a pose's attitude, R = Rz(yaw)·Ry(pitch)·Rx(roll).
Mat3 murp_rotation(const MurpPose& pose);

}  // namespace swarmloc::world
