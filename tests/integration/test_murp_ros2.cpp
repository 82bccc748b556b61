// `swarmloc replay --murp --ros2` (docs/ros2.md, "MURP relative poses"): MURP trial 13 over DDS (three
// vehicle processes, domain 47) read by tests/ros2_reader --murp, an independent ROS 2-style reader (plain
// Cyclone C, its own IDL written from the ROS .msg files, ROS 2's DDS names and QoS). Every published pose
// must equal its relative.csv row (position and heading to 1e-9, the std columns from the covariance), its
// roll and pitch the peer's IMU tilt in that window computed here from the dataset files, and the truth
// topics relative.csv's truth columns. Without --ros2 no rt/ topic is published; --sim refuses --ros2.
// Skipped, with a message, when the dataset is absent (tests/support/dataset_paths.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "dataset_paths.hpp"
#include "process_helpers.hpp"
#include "ros2_reader_lines.hpp"

namespace murp_ros2_test {
namespace {

namespace fs = std::filesystem;
using swarmloc::testing::count_processes_matching;
using swarmloc::testing::fresh_directory;
using swarmloc::testing::read_json;
using swarmloc::testing::read_text;
using swarmloc::testing::run_command;

const std::string kMurpRos2Binary = SWARMLOC_BINARY;
const std::string kMurpRos2Reader = SWARMLOC_ROS2_READER;
const std::string kMurpRos2Source = SWARMLOC_SOURCE_DIR;
constexpr int kMurpRos2Domain = 47;
constexpr double kMurpRos2UnknownVariance = 1e9;

fs::path murp_ros2_trial13() {
  const auto parsed = swarmloc::testing::murp_parsed(SWARMLOC_SOURCE_DIR);
  return !parsed.empty() && fs::exists(parsed / "13") ? parsed / "13" : fs::path();
}

#define MURP_ROS2_SKIP_WITHOUT_DATA(dir)                                                                  \
  if ((dir).empty()) {                                                                                    \
    GTEST_SKIP() << "MIT MURP dataset not found (looked for shared/data/mit-murp-uwb/parsed beside "      \
                 << SWARMLOC_SOURCE_DIR << " and its parents; set SWARMLOC_MURP_DIR to its parsed/ dir)"; \
  }

/// One murp_pose or murp_truth line of the reader.
struct MurpRos2Sample {
  int observer = 0;
  int peer = 0;
  std::int64_t stamp_ns = 0;
  std::string frame;
  std::vector<double> values;  ///< x y z qx qy qz qw, then (poses) the 36 covariance entries
  [[nodiscard]] double covariance(int row, int col) const {
    return values.at(static_cast<std::size_t>(7 + 6 * row + col));
  }
};

using MurpRos2Key = std::tuple<int, int, std::int64_t>;  ///< observer, peer, stamp

struct MurpRos2ReaderOutput {
  std::map<MurpRos2Key, std::vector<MurpRos2Sample>> poses;
  std::map<MurpRos2Key, std::vector<MurpRos2Sample>> truth;
  std::set<std::pair<std::string, std::string>> publications;  ///< (topic, type)
  std::size_t pose_count = 0;
  std::size_t truth_count = 0;
};

MurpRos2ReaderOutput parse_murp_ros2_reader(const std::string& text) {
  MurpRos2ReaderOutput out;
  swarmloc::testing::for_each_ros2_reader_line(text, [&](const std::string& kind, std::istringstream& in) {
    if (kind == "murp_pose" || kind == "murp_truth") {
      MurpRos2Sample sample;
      in >> sample.observer >> sample.peer;
      sample.stamp_ns = swarmloc::testing::read_ros2_stamp_ns(in);
      in >> sample.frame;
      for (double value = 0.0; in >> value;) sample.values.push_back(value);
      const MurpRos2Key key{sample.observer, sample.peer, sample.stamp_ns};
      auto& into = kind == "murp_pose" ? out.poses : out.truth;
      (kind == "murp_pose" ? out.pose_count : out.truth_count) += 1;
      into[key].push_back(std::move(sample));
    } else if (kind == "publication") {
      std::string topic, type;
      in >> topic >> type;
      out.publications.emplace(topic, type);
    }
  });
  return out;
}

/// relative.csv, by column name.
struct MurpRos2Csv {
  std::map<std::string, std::size_t> columns;
  std::vector<std::vector<double>> rows;
  [[nodiscard]] double at(const std::vector<double>& row, const std::string& name) const {
    return row.at(columns.at(name));
  }
};

MurpRos2Csv read_murp_ros2_csv(const fs::path& path) {
  MurpRos2Csv csv;
  std::istringstream lines(read_text(path));
  std::string line;
  std::getline(lines, line);
  std::istringstream header(line);
  for (std::string name; std::getline(header, name, ',');) csv.columns.emplace(name, csv.columns.size());
  while (std::getline(lines, line)) {
    std::vector<double> row;
    std::istringstream cells(line);
    for (std::string cell; std::getline(cells, cell, ',');) row.push_back(std::strtod(cell.c_str(), nullptr));
    csv.rows.push_back(std::move(row));
  }
  return csv;
}

struct MurpRos2Tilt {
  double roll = 0.0;
  double pitch = 0.0;
};

/// Each vehicle's IMU roll and pitch by window time, from the trial's files: the A_ and B_ mocap angles
/// (degrees) with the authors' R = Rx(roll)·Ry(pitch)·Rz(yaw) (docs/real-data.md, "How a trial becomes a
/// run"), as an IMU reports them for R = Rz(yaw')·Ry(pitch')·Rx(roll'): roll' = atan2(R21, R22),
/// pitch' = −asin(R20). Written here from the files, not through the loader.
std::map<int, std::map<double, MurpRos2Tilt>> murp_ros2_tilts(const fs::path& trial) {
  std::map<int, std::map<double, MurpRos2Tilt>> tilts;
  for (const auto& entry : fs::directory_iterator(trial)) {
    const std::string name = entry.path().filename().string();
    const auto base_at = name.find("_base-");
    const auto target_at = name.find("_targ-");
    if (base_at == std::string::npos || target_at == std::string::npos) continue;
    const int base = std::stoi(name.substr(base_at + 6));
    const int target = std::stoi(name.substr(target_at + 6));
    const auto text = run_command("zcat -f '" + entry.path().string() + "'").output;
    std::istringstream lines(text);
    std::string line;
    std::getline(lines, line);
    std::map<std::string, std::size_t> columns;
    std::istringstream header(line);
    for (std::string column; std::getline(header, column, ',');) columns.emplace(column, columns.size());
    while (std::getline(lines, line)) {
      std::vector<double> cells;
      std::istringstream in(line);
      for (std::string cell; std::getline(in, cell, ',');)
        cells.push_back(std::strtod(cell.c_str(), nullptr));
      if (cells.size() != columns.size()) continue;
      const double time = cells[columns.at("t")];
      for (const auto& [vehicle, prefix] :
           {std::pair{base, std::string("A_")}, std::pair{target, std::string("B_")}}) {
        constexpr double kDeg = std::numbers::pi / 180.0;
        const double r = cells[columns.at(prefix + "roll")] * kDeg;
        const double p = cells[columns.at(prefix + "pitch")] * kDeg;
        const double y = cells[columns.at(prefix + "yaw")] * kDeg;
        // Rx(r)·Ry(p)·Rz(y): its bottom row is (−cos r·sin p·cos y + sin r·sin y, cos r·sin p·sin y + sin
        // r·cos y, cos r·cos p).
        const double r20 = -std::cos(r) * std::sin(p) * std::cos(y) + std::sin(r) * std::sin(y);
        const double r21 = std::cos(r) * std::sin(p) * std::sin(y) + std::sin(r) * std::cos(y);
        const double r22 = std::cos(r) * std::cos(p);
        tilts[vehicle].emplace(time,
                               MurpRos2Tilt{std::atan2(r21, r22), -std::asin(std::clamp(r20, -1.0, 1.0))});
      }
    }
  }
  return tilts;
}

/// The tilt of `vehicle` at `time`, or its last one before (what its observers' filters use when a window
/// has no pose of it).
MurpRos2Tilt murp_ros2_tilt_at(const std::map<int, std::map<double, MurpRos2Tilt>>& tilts, int vehicle,
                               double time) {
  const auto& by_time = tilts.at(vehicle);
  auto found = by_time.upper_bound(time);
  if (found == by_time.begin()) return {};
  return std::prev(found)->second;
}

/// Rotation matrix of a unit quaternion (x, y, z, w), row-major.
std::array<double, 9> murp_ros2_rotation(double x, double y, double z, double w) {
  return {1 - 2 * (y * y + z * z), 2 * (x * y - z * w),     2 * (x * z + y * w),
          2 * (x * y + z * w),     1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
          2 * (x * z - y * w),     2 * (y * z + x * w),     1 - 2 * (x * x + y * y)};
}

struct MurpRos2Attitude {
  double yaw = 0.0, pitch = 0.0, roll = 0.0;
};

/// (yaw, pitch, roll) of R = Rz(yaw)·Ry(pitch)·Rx(roll) from a sample's quaternion.
MurpRos2Attitude murp_ros2_attitude(const MurpRos2Sample& sample) {
  const auto& v = sample.values;
  const auto r = murp_ros2_rotation(v[3], v[4], v[5], v[6]);
  return {std::atan2(r[3], r[0]), -std::asin(std::clamp(r[6], -1.0, 1.0)), std::atan2(r[7], r[8])};
}

double murp_ros2_angle_difference(double a, double b) {
  return std::remainder(a - b, 2.0 * std::numbers::pi);
}

struct MurpRos2Run {
  int exit_code = -1;
  std::string output;
  fs::path dir;
  MurpRos2ReaderOutput reader;
  std::string reader_stderr;
};

/// When the reader starts and how it finds the run.
enum class MurpRos2ReaderStart {
  /// Before the run, pinging the run's fixed ports every 0.1 s instead of deploy/ros2/cyclonedds.xml's 1 s.
  kFirstFastPing,
  /// 1.5 s after the run (longer than a whole run that does not wait for it), with the shipped file.
  kLateShippedFile,
};

/// `replay --murp` of trial 13 over DDS with `flags`, beside the reader (which ends by itself once the ROS
/// writers are gone, or is stopped a second after the run).
MurpRos2Run run_murp_with_ros2_reader(const std::string& name, const fs::path& trial,
                                      const std::string& flags, MurpRos2ReaderStart start) {
  MurpRos2Run run;
  run.dir = fresh_directory(name);
  const auto reader_out = run.dir.parent_path() / (run.dir.filename().string() + "-reader.out");
  const auto reader_err = run.dir.parent_path() / (run.dir.filename().string() + "-reader.err");
  std::string uri = "file://" + kMurpRos2Source + "/deploy/ros2/cyclonedds.xml";
  if (start == MurpRos2ReaderStart::kFirstFastPing)
    uri += ",<Discovery><SPDPInterval>0.1s</SPDPInterval></Discovery>";
  const std::string reader = "CYCLONEDDS_URI='" + uri + "' " + kMurpRos2Reader + " --murp " +
                             std::to_string(kMurpRos2Domain) + " 1,2,3 60 >" + reader_out.string() + " 2>" +
                             reader_err.string() + " & reader=$!; ";
  const std::string replay = kMurpRos2Binary + " replay --murp " + trial.string() + " --domain " +
                             std::to_string(kMurpRos2Domain) + flags + " -q --force --out " +
                             run.dir.string();
  const std::string command = (start == MurpRos2ReaderStart::kFirstFastPing
                                   ? reader + replay + "; code=$?; "
                                   : replay + " & run=$!; sleep 1.5; " + reader + "wait $run; code=$?; ") +
                              "sleep 1; kill $reader 2>/dev/null; wait $reader 2>/dev/null; exit $code";
  const auto result = run_command(command);
  run.exit_code = result.exit_code;
  run.output = result.output;
  run.reader = parse_murp_ros2_reader(read_text(reader_out));
  run.reader_stderr = read_text(reader_err);
  return run;
}

class MurpRos2 : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    trial_ = murp_ros2_trial13();
    if (trial_.empty()) return;
    // The reader starts after a run that did not wait for it would be over: --ros2-subscribers 12 holds
    // the first window until it has matched all twelve topics.
    run_ = new MurpRos2Run(run_murp_with_ros2_reader("murp-ros2", trial_, " --ros2 --ros2-subscribers 12",
                                                     MurpRos2ReaderStart::kLateShippedFile));
  }
  static void TearDownTestSuite() {
    delete run_;
    run_ = nullptr;
  }
  static const fs::path& trial() { return trial_; }
  static const MurpRos2Run& run() { return *run_; }

 private:
  static fs::path trial_;
  static MurpRos2Run* run_;
};

fs::path MurpRos2::trial_;
MurpRos2Run* MurpRos2::run_ = nullptr;

TEST_F(MurpRos2, EveryEstimateIsOnePoseEqualToItsRelativeCsvRowWithThePeersTilt) {
  MURP_ROS2_SKIP_WITHOUT_DATA(trial());
  ASSERT_EQ(run().exit_code, 0) << run().output << run().reader_stderr;
  const auto csv = read_murp_ros2_csv(run().dir / "relative.csv");
  ASSERT_GT(csv.rows.size(), 1000U);  // trial 13: 177 windows, six ordered pairs
  const auto tilts = murp_ros2_tilts(trial());
  ASSERT_EQ(tilts.size(), 3U);
  std::size_t tilted = 0;
  for (const auto& row : csv.rows) {
    const int observer = static_cast<int>(csv.at(row, "base"));
    const int peer = static_cast<int>(csv.at(row, "target"));
    const double time = csv.at(row, "time_s");
    const MurpRos2Key key{observer, peer, std::llround(time * 1e9)};
    const auto found = run().reader.poses.find(key);
    ASSERT_NE(found, run().reader.poses.end())
        << "no pose of " << peer << " by " << observer << " at " << time << " s\n"
        << run().reader_stderr;
    ASSERT_EQ(found->second.size(), 1U) << "window at " << time << " s published twice";
    const MurpRos2Sample& pose = found->second.front();
    ASSERT_EQ(pose.values.size(), 7U + 36U);
    EXPECT_EQ(pose.frame, "vehicle_" + std::to_string(observer) + "/level");
    const std::string where =
        std::to_string(observer) + " sees " + std::to_string(peer) + " at " + std::to_string(time) + " s";
    EXPECT_NEAR(pose.values[0], csv.at(row, "x_m"), 1e-9) << where;
    EXPECT_NEAR(pose.values[1], csv.at(row, "y_m"), 1e-9) << where;
    EXPECT_NEAR(pose.values[2], csv.at(row, "z_m"), 1e-9) << where;
    const double norm = std::hypot(pose.values[3], pose.values[4], pose.values[5]);
    EXPECT_NEAR(std::hypot(norm, pose.values[6]), 1.0, 1e-12) << where;
    const MurpRos2Attitude attitude = murp_ros2_attitude(pose);
    EXPECT_NEAR(murp_ros2_angle_difference(attitude.yaw, csv.at(row, "heading_rad")), 0.0, 1e-9) << where;
    const MurpRos2Tilt tilt = murp_ros2_tilt_at(tilts, peer, time);
    EXPECT_NEAR(attitude.roll, tilt.roll, 1e-9) << where;
    EXPECT_NEAR(attitude.pitch, tilt.pitch, 1e-9) << where;
    tilted += std::abs(tilt.roll) > 1e-4 && std::abs(tilt.pitch) > 1e-4 ? 1 : 0;
    // The covariance: x, y, z and heading from the estimate (relative.csv has their stds), roll and pitch
    // unknown, symmetric.
    EXPECT_NEAR(std::sqrt(pose.covariance(0, 0)), csv.at(row, "std_x_m"), 1e-9) << where;
    EXPECT_NEAR(std::sqrt(pose.covariance(1, 1)), csv.at(row, "std_y_m"), 1e-9) << where;
    EXPECT_NEAR(std::sqrt(pose.covariance(2, 2)), csv.at(row, "std_z_m"), 1e-9) << where;
    EXPECT_NEAR(std::sqrt(pose.covariance(5, 5)), csv.at(row, "std_heading_rad"), 1e-9) << where;
    for (int r = 0; r < 6; ++r) {
      for (int c = 0; c < 6; ++c) {
        EXPECT_EQ(pose.covariance(r, c), pose.covariance(c, r)) << where;
        if ((r == 3 || r == 4 || c == 3 || c == 4) && r != c) {
          EXPECT_EQ(pose.covariance(r, c), 0.0) << where;
        }
      }
    }
    EXPECT_EQ(pose.covariance(3, 3), kMurpRos2UnknownVariance);
    EXPECT_EQ(pose.covariance(4, 4), kMurpRos2UnknownVariance);
  }
  EXPECT_EQ(run().reader.pose_count, csv.rows.size()) << "poses that relative.csv does not hold";
  EXPECT_GT(tilted, csv.rows.size() / 2);  // roll and pitch are really there, not zeros that pass
  const auto summary = read_json(run().dir / "summary.json");
  EXPECT_EQ(summary["extra"]["dds"]["ros2_write_timeouts"], 0);
  std::printf("murp ros2: %zu poses, %zu truths read\n", run().reader.pose_count, run().reader.truth_count);
}

TEST_F(MurpRos2, TruthTopicsCarryRelativeCsvsTruthColumns) {
  MURP_ROS2_SKIP_WITHOUT_DATA(trial());
  ASSERT_EQ(run().exit_code, 0) << run().output;
  const auto csv = read_murp_ros2_csv(run().dir / "relative.csv");
  const auto tilts = murp_ros2_tilts(trial());
  std::size_t compared = 0;
  for (const auto& row : csv.rows) {
    if (std::isnan(csv.at(row, "truth_x_m"))) continue;
    const int observer = static_cast<int>(csv.at(row, "base"));
    const int peer = static_cast<int>(csv.at(row, "target"));
    const double time = csv.at(row, "time_s");
    const auto found = run().reader.truth.find({observer, peer, std::llround(time * 1e9)});
    ASSERT_NE(found, run().reader.truth.end())
        << "no truth of " << peer << " by " << observer << " at " << time;
    ASSERT_EQ(found->second.size(), 1U);
    const MurpRos2Sample& truth = found->second.front();
    ASSERT_EQ(truth.values.size(), 7U);
    EXPECT_EQ(truth.frame, "vehicle_" + std::to_string(observer) + "/level");
    EXPECT_NEAR(truth.values[0], csv.at(row, "truth_x_m"), 1e-9);
    EXPECT_NEAR(truth.values[1], csv.at(row, "truth_y_m"), 1e-9);
    EXPECT_NEAR(truth.values[2], csv.at(row, "truth_z_m"), 1e-9);
    const MurpRos2Attitude attitude = murp_ros2_attitude(truth);
    EXPECT_NEAR(murp_ros2_angle_difference(attitude.yaw, csv.at(row, "truth_heading_rad")), 0.0, 1e-9);
    const MurpRos2Tilt tilt = murp_ros2_tilt_at(tilts, peer, time);
    EXPECT_NEAR(attitude.roll, tilt.roll, 1e-9);
    EXPECT_NEAR(attitude.pitch, tilt.pitch, 1e-9);
    ++compared;
  }
  EXPECT_GT(compared, csv.rows.size() * 9 / 10);
  // A truth per pair and window of the files, at most: never more samples than keys.
  EXPECT_EQ(run().reader.truth_count, run().reader.truth.size());
}

TEST_F(MurpRos2, DcpsPublicationShowsTheTwelveRosTopicsWithRosTypeNames) {
  MURP_ROS2_SKIP_WITHOUT_DATA(trial());
  ASSERT_EQ(run().exit_code, 0) << run().output;
  std::set<std::pair<std::string, std::string>> expected;
  for (int observer = 1; observer <= 3; ++observer) {
    for (int peer = 1; peer <= 3; ++peer) {
      if (peer == observer) continue;
      const std::string prefix =
          "rt/swarmloc/murp/vehicle_" + std::to_string(observer) + "/vehicle_" + std::to_string(peer);
      expected.emplace(prefix + "/pose", "geometry_msgs::msg::dds_::PoseWithCovarianceStamped_");
      expected.emplace(prefix + "/truth", "geometry_msgs::msg::dds_::PoseStamped_");
    }
  }
  std::set<std::pair<std::string, std::string>> ros;
  for (const auto& publication : run().reader.publications) {
    if (publication.first.starts_with("rt/")) ros.insert(publication);
  }
  EXPECT_EQ(ros, expected);
  EXPECT_EQ(count_processes_matching(run().dir.string()), 0);
}

TEST(MurpRos2Off, WithoutRos2NoRosTopicIsPublished) {
  const auto trial = murp_ros2_trial13();
  MURP_ROS2_SKIP_WITHOUT_DATA(trial);
  // Pinging every 0.1 s: this run does not wait for the reader and lasts under a second, and the reader must
  // still see its writers for the absence of rt/ ones to mean anything.
  const MurpRos2Run run =
      run_murp_with_ros2_reader("murp-ros2-off", trial, "", MurpRos2ReaderStart::kFirstFastPing);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  int ros_topics = 0, window_writers = 0;
  for (const auto& [topic, type] : run.reader.publications) {
    ros_topics += topic.starts_with("rt/") ? 1 : 0;
    window_writers += topic == "swarmloc_uwb_window" ? 1 : 0;
  }
  EXPECT_EQ(ros_topics, 0);
  EXPECT_EQ(run.reader.pose_count + run.reader.truth_count, 0U);
  // The reader did discover the run's orchestrator, so the absence of rt/ topics means something.
  EXPECT_EQ(window_writers, 1) << run.reader_stderr;
}

TEST(MurpRos2BadInput, Ros2IsRefusedWithSimAndWithoutMurp) {
  const auto dir = fresh_directory("murp-ros2-bad");
  const auto with_sim = run_command(kMurpRos2Binary + " replay --murp " + dir.string() +
                                    " --sim --ros2 -q --force --out " + (dir / "out").string());
  EXPECT_EQ(with_sim.exit_code, 2) << with_sim.output;
  EXPECT_NE(with_sim.output.find("--ros2"), std::string::npos) << with_sim.output;
  const auto without_murp =
      run_command(kMurpRos2Binary + " replay " + dir.string() + "/recording.slrec --ros2 -q");
  EXPECT_EQ(without_murp.exit_code, 2) << without_murp.output;
  EXPECT_NE(without_murp.output.find("--ros2"), std::string::npos) << without_murp.output;
}

}  // namespace
}  // namespace murp_ros2_test
