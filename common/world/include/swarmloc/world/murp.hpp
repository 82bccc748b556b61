#pragma once
// MIT ACL MURP multi-agent UWB dataset (Fishberg, Quiter, How, RA-L 2024; docs/real-data.md, "MURP"): three
// vehicles with six UWB antennas each, one file per ordered pair (base A, target B) and trial, one row per
// 1-s window: the 36 antenna-pair ranges averaged over the window, and both vehicles' motion-capture poses.
// The data is read from the user's directory (plain .csv or gzip-compressed .csv.gz), never shipped.
#include <array>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "swarmloc/core/types.hpp"

namespace swarmloc::world {

inline constexpr int kMurpVehicles = 3;
inline constexpr int kMurpAntennas = 6;

/// A vehicle's pose: position (m) and roll, pitch, yaw (rad) as the files give them (murp_rotation).
struct MurpPose {
  Vec3 position_m = Vec3::Zero();
  double roll_rad = 0.0;
  double pitch_rad = 0.0;
  double yaw_rad = 0.0;
};

using MurpAntennaMatrix = Eigen::Matrix<double, kMurpAntennas, kMurpAntennas>;

/// One window of one ordered pair: ranges_m(i, j) is the mean range from antenna i of the base to antenna j
/// of the target (0-based, column "{i+1}_{j+1}"); NaN where the window has no valid reading of that antenna
/// pair (an empty, non-finite or non-positive field).
struct MurpWindow {
  double time_s = 0.0;  ///< window start, seconds since the trial's start (column t as given)
  MurpPose base;        ///< motion-capture pose of the base over the window
  MurpPose target;
  MurpAntennaMatrix ranges_m = MurpAntennaMatrix::Constant(std::numeric_limits<double>::quiet_NaN());
  /// Std of the readings averaged ("{i+1}_{j+1}_std"); NaN where the range is NaN or the field is empty
  /// or non-finite (a window with one reading has none).
  MurpAntennaMatrix range_std_m = MurpAntennaMatrix::Constant(std::numeric_limits<double>::quiet_NaN());
  /// The dataset authors' truth range ("{i+1}_{j+1}_t"), computed by them from the motion-capture poses
  /// and their ring model of the antennas, not measured; NaN where the file has no such column.
  MurpAntennaMatrix truth_ranges_m = MurpAntennaMatrix::Constant(std::numeric_limits<double>::quiet_NaN());
  /// The number of antenna pairs with a range (not NaN).
  [[nodiscard]] int valid_ranges() const;
};

/// The windows of one ordered pair (vehicles numbered 1–3 as in the file names).
struct MurpPairLog {
  int base = 0;
  int target = 0;
  std::filesystem::path file;
  std::vector<MurpWindow> windows;
  int skipped_windows = 0;  ///< rows dropped: fewer than kMurpMinValidRanges valid ranges, or a pose field
                            ///< empty or non-finite
};

/// Windows with fewer valid ranges than this carry too little to place a vehicle (three position
/// coordinates and a heading) and are skipped and counted.
inline constexpr int kMurpMinValidRanges = 4;

struct MurpTrial {
  std::string name;  ///< the trial number as in the file names ("13")
  std::filesystem::path directory;
  std::vector<MurpPairLog> pairs;  ///< all six ordered pairs, (1,2), (1,3), (2,1), (2,3), (3,1), (3,2)
  /// The log of the ordered pair (base, target); throws std::out_of_range for any other pair.
  [[nodiscard]] const MurpPairLog& pair(int base, int target) const;
};

/// Reads the six files NN_base-A_targ-B_win-1_step-1.csv[.gz] of `directory` (NN found from the files;
/// a plain .csv is preferred to a .csv.gz of the same pair). Columns are found by name in the header;
/// angles are converted from degrees. Throws config::ScenarioError naming the directory when it holds no
/// such file or files of more than one trial, naming the pair when one is missing, and naming the file (and
/// line) for a file that is not readable text or gzip, a header without the expected columns, or a row
/// with a field count other than the header's (a truncated row) or a field that is not a number. An empty
/// field is a missing value (the files have some). Empty, non-finite or non-positive ranges become NaN
/// (not used); a row with fewer than kMurpMinValidRanges valid ranges, or with an empty or non-finite pose
/// field or time, is skipped and counted in skipped_windows: one bad window need not cost the trial.
MurpTrial load_murp_trial(const std::filesystem::path& directory);

/// Rotation of a pose's attitude in the dataset authors' convention, R = Rx(roll)·Ry(pitch)·Rz(yaw): it
/// reproduces their derived columns (I_J_t, the relative pose) to under 0.01 mm in every trial, where
/// Rz(yaw)·Ry(pitch)·Rx(roll) leaves 1.3–3.3 mm RMS (docs/real-data.md, "MURP"). murp_team converts it to the
/// yaw, pitch, roll an IMU reports.
Mat3 murp_rotation(const MurpPose& pose);

}  // namespace swarmloc::world
