// dds.ros2 (docs/ros2.md): a 20-agent run read by an independent ROS 2-style reader
// (tests/ros2_reader: plain Cyclone C, IDL written from the ROS .msg files, ROS 2's exact DDS type names
// and default QoS) through the shipped deploy/ros2/cyclonedds.xml. The reader's poses must equal the run
// directory's estimates.csv, its truth arrays the truth columns, and the DCPSPublication built-in topic
// must show exactly the ROS 2 type names on rt/swarmloc/… topics.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "process_helpers.hpp"
#include "ros2_reader_lines.hpp"

namespace ros2_test {
namespace {

using swarmloc::testing::fresh_directory;
using swarmloc::testing::read_text;
using swarmloc::testing::run_command;

const std::string kRos2Binary = SWARMLOC_BINARY;
const std::string kRos2Reader = SWARMLOC_ROS2_READER;
const std::string kRos2Source = SWARMLOC_SOURCE_DIR;

constexpr int kRos2Agents = 20;
constexpr int kRos2Steps = 40;
constexpr double kRos2RateHz = 10.0;  // the default scenario's run.rate_hz
constexpr double kRos2UnknownVariance = 1e9;

struct Ros2Pose {
  std::int64_t stamp_ns = 0;
  std::string frame;
  std::vector<double> values;  ///< x y z qx qy qz qw, then the 36 covariance entries
  [[nodiscard]] double covariance(int row, int col) const {
    return values.at(static_cast<std::size_t>(7 + 6 * row + col));
  }
};

struct Ros2TruthArray {
  std::int64_t stamp_ns = 0;
  std::string frame;
  std::vector<std::array<double, 4>> poses;  ///< x y z qw
};

struct Ros2RangeArray {
  std::int64_t step = -1;
  std::int64_t stamp_ns = 0;
  struct Entry {
    int agent = 0;
    int peer = 0;
    double range_m = 0.0;
    double std_m = 0.0;
  };
  std::vector<Entry> ranges;
};

/// What tests/ros2_reader printed (its line formats are documented there).
struct Ros2ReaderOutput {
  std::map<int, std::vector<Ros2Pose>> poses;  ///< by agent, in arrival order
  std::vector<Ros2TruthArray> truth;
  std::vector<Ros2RangeArray> ranges;
  std::multiset<std::pair<std::string, std::string>> publications;  ///< (topic name, type name) per writer
};

Ros2ReaderOutput parse_ros2_reader_output(const std::string& text) {
  using swarmloc::testing::read_ros2_stamp_ns;
  Ros2ReaderOutput out;
  swarmloc::testing::for_each_ros2_reader_line(text, [&](const std::string& kind, std::istringstream& in) {
    if (kind == "pose") {
      int agent = -1;
      in >> agent;
      Ros2Pose pose;
      pose.stamp_ns = read_ros2_stamp_ns(in);
      in >> pose.frame;
      double value = 0.0;
      while (in >> value) pose.values.push_back(value);
      out.poses[agent].push_back(std::move(pose));
    } else if (kind == "truth") {
      Ros2TruthArray array;
      array.stamp_ns = read_ros2_stamp_ns(in);
      std::size_t count = 0;
      in >> array.frame >> count;
      array.poses.resize(count);
      for (auto& pose : array.poses) in >> pose[0] >> pose[1] >> pose[2] >> pose[3];
      out.truth.push_back(std::move(array));
    } else if (kind == "ranges") {
      Ros2RangeArray array;
      in >> array.step;
      array.stamp_ns = read_ros2_stamp_ns(in);
      std::string frame;
      std::size_t count = 0;
      in >> frame >> count;
      array.ranges.resize(count);
      for (auto& r : array.ranges) in >> r.agent >> r.peer >> r.range_m >> r.std_m;
      out.ranges.push_back(std::move(array));
    } else if (kind == "publication") {
      std::string topic, type;
      in >> topic >> type;
      out.publications.emplace(topic, type);
    }
  });
  return out;
}

/// One row of estimates.csv.
struct Ros2EstimateRow {
  std::int64_t step = 0;
  int agent = 0;
  double x = 0, y = 0, cov_xx = 0, cov_xy = 0, cov_yy = 0;
  bool valid = false;
  double truth_x = 0, truth_y = 0;
  double z = 0, cov_zz = 0, truth_z = 0;  ///< a 3-D world's columns (0 in a planar one)
};

std::vector<Ros2EstimateRow> read_ros2_estimates_csv(const std::filesystem::path& path) {
  std::vector<Ros2EstimateRow> rows;
  std::istringstream lines(read_text(path));
  std::string line;
  std::getline(lines, line);  // step,agent,x_m,y_m,cov_xx,cov_xy,cov_yy,valid,truth_x_m,truth_y_m,error_m
  while (std::getline(lines, line)) {
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream in(line);
    Ros2EstimateRow row;
    int valid = 0;
    in >> row.step >> row.agent >> row.x >> row.y >> row.cov_xx >> row.cov_xy >> row.cov_yy >> valid >>
        row.truth_x >> row.truth_y;
    row.valid = valid != 0;
    double error = 0.0, inconsistent = 0.0, cov_xz = 0.0, cov_yz = 0.0;
    in >> error >> inconsistent >> row.z >> cov_xz >> cov_yz >> row.cov_zz >> row.truth_z;
    rows.push_back(row);
  }
  return rows;
}

/// The reader runs beside `swarmloc run` and ends by itself once the run's writers are gone (ros2 on),
/// or is stopped a second after the run (ros2 off: it never meets a ROS writer).
struct Ros2Run {
  int exit_code = -1;
  std::string output;
  std::filesystem::path dir;
  Ros2ReaderOutput reader;
  std::string reader_stderr;
};

Ros2Run run_with_ros2_reader(const std::string& name, int domain, int agents, const std::string& flags,
                             const std::string& scenario = "ieif") {
  Ros2Run run;
  run.dir = fresh_directory(name);
  const auto reader_out = run.dir.parent_path() / (run.dir.filename().string() + "-reader.out");
  const auto reader_err = run.dir.parent_path() / (run.dir.filename().string() + "-reader.err");
  const std::string command =
      "CYCLONEDDS_URI=file://" + kRos2Source + "/deploy/ros2/cyclonedds.xml " + kRos2Reader + " " +
      std::to_string(domain) + " " + std::to_string(agents) + " 120 >" + reader_out.string() + " 2>" +
      reader_err.string() + " & reader=$!; " + kRos2Binary + " run " + kRos2Source + "/scenarios/" +
      scenario + ".yaml -q --out " + run.dir.string() + " --set world.agents=" + std::to_string(agents) +
      " --set world.anchors=" + std::to_string(agents >= 10 ? 6 : 3) +
      " --set run.steps=" + std::to_string(kRos2Steps) + " --set dds.domain_id=" + std::to_string(domain) +
      flags + "; code=$?; sleep 1; kill $reader 2>/dev/null; wait $reader; exit $code";
  const auto result = run_command(command);
  run.exit_code = result.exit_code;
  run.output = result.output;
  run.reader = parse_ros2_reader_output(read_text(reader_out));
  run.reader_stderr = read_text(reader_err);
  return run;
}

/// Equal to 1e-6 (relative beyond magnitude 1: estimates.csv prints 9 significant digits, and a first-step
/// covariance can be ~1e5).
bool ros2_near(double a, double b) { return std::abs(a - b) <= 1e-6 * std::max(1.0, std::abs(b)); }

class Ros2OverDds : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // A moving truth, so that a truth array of the wrong step cannot pass.
    run_ = new Ros2Run(run_with_ros2_reader(
        "ros2", 71, kRos2Agents,
        " --set dds.ros2=true --set world.motion=random_walk --set world.motion_std_m=0.02"));
  }
  static void TearDownTestSuite() {
    delete run_;
    run_ = nullptr;
  }
  static const Ros2Run& run() { return *run_; }

 private:
  static Ros2Run* run_;
};

Ros2Run* Ros2OverDds::run_ = nullptr;

TEST_F(Ros2OverDds, IndependentReaderReceivesEveryAgentsPoseEqualToEstimatesCsv) {
  ASSERT_TRUE(swarmloc::testing::completed_run(run().exit_code)) << run().output;
  const auto rows = read_ros2_estimates_csv(run().dir / "estimates.csv");
  std::size_t rows_matched = 0;
  for (int agent = 0; agent < kRos2Agents; ++agent) {
    const auto found = run().reader.poses.find(agent);
    ASSERT_NE(found, run().reader.poses.end()) << "no pose from agent " << agent << "\n"
                                               << run().reader_stderr;
    const auto& poses = found->second;
    for (std::size_t k = 0; k < poses.size(); ++k) {
      const Ros2Pose& pose = poses[k];
      ASSERT_EQ(pose.values.size(), 7U + 36U);
      EXPECT_EQ(pose.frame, "map");
      // Position-only algorithm (ieif): z = 0, identity orientation, only the x-y block estimated.
      EXPECT_EQ(pose.values[2], 0.0);
      EXPECT_EQ(pose.values[3], 0.0);
      EXPECT_EQ(pose.values[4], 0.0);
      EXPECT_EQ(pose.values[5], 0.0);
      EXPECT_EQ(pose.values[6], 1.0);
      EXPECT_EQ(pose.covariance(0, 1), pose.covariance(1, 0));
      for (int row = 0; row < 6; ++row) {
        for (int col = 0; col < 6; ++col) {
          if (row < 2 && col < 2) continue;
          EXPECT_EQ(pose.covariance(row, col), row == col ? kRos2UnknownVariance : 0.0)
              << "agent " << agent << " covariance(" << row << ", " << col << ")";
        }
      }
      // Stamped with the agent's own clock, which only moves forward.
      if (k > 0) {
        EXPECT_GE(pose.stamp_ns, poses[k - 1].stamp_ns) << "agent " << agent;
      }
    }
    // Every valid row of this agent (step order) is one of its poses, taken in order: the orchestrator
    // scores each world step with the newest report it holds, and every report of a step run is also a
    // pose (one pose can score several steps).
    std::size_t next = 0;
    for (const auto& row : rows) {
      if (row.agent != agent || !row.valid) continue;
      auto matches = [&row](const Ros2Pose& pose) {
        return ros2_near(pose.values[0], row.x) && ros2_near(pose.values[1], row.y) &&
               ros2_near(pose.covariance(0, 0), row.cov_xx) && ros2_near(pose.covariance(0, 1), row.cov_xy) &&
               ros2_near(pose.covariance(1, 1), row.cov_yy);
      };
      while (next < poses.size() && !matches(poses[next])) ++next;
      ASSERT_LT(next, poses.size()) << "agent " << agent << " step " << row.step << ": estimates.csv has ("
                                    << row.x << ", " << row.y << "), which no later pose carries";
      ++rows_matched;
    }
  }
  // Every agent (anchors included) is scored at every step of a healthy run.
  EXPECT_GE(rows_matched, static_cast<std::size_t>(kRos2Agents * kRos2Steps) * 9 / 10);
  std::printf(
      "ros2: %zu estimates.csv rows matched by %zu poses of %d agents\n", rows_matched,
      [&] {
        std::size_t total = 0;
        for (const auto& [agent, poses] : run().reader.poses) total += poses.size();
        return total;
      }(),
      kRos2Agents);
}

TEST_F(Ros2OverDds, TruthPoseArrayEqualsTheTruthColumns) {
  ASSERT_TRUE(swarmloc::testing::completed_run(run().exit_code)) << run().output;
  std::map<std::int64_t, const Ros2TruthArray*> by_step;
  for (const auto& array : run().reader.truth) {
    // World time of step k is k / run.rate_hz.
    const auto step =
        static_cast<std::int64_t>(std::llround(static_cast<double>(array.stamp_ns) * 1e-9 * kRos2RateHz));
    EXPECT_TRUE(by_step.emplace(step, &array).second) << "two truth arrays for step " << step;
    EXPECT_EQ(array.frame, "map");
    ASSERT_EQ(array.poses.size(), static_cast<std::size_t>(kRos2Agents));
  }
  EXPECT_EQ(by_step.size(), static_cast<std::size_t>(kRos2Steps));
  std::size_t compared = 0;
  for (const auto& row : read_ros2_estimates_csv(run().dir / "estimates.csv")) {
    const auto found = by_step.find(row.step);
    ASSERT_NE(found, by_step.end()) << "no truth array for step " << row.step;
    const auto& pose = found->second->poses.at(static_cast<std::size_t>(row.agent));
    EXPECT_TRUE(ros2_near(pose[0], row.truth_x) && ros2_near(pose[1], row.truth_y))
        << "step " << row.step << " agent " << row.agent << ": (" << pose[0] << ", " << pose[1] << ") vs ("
        << row.truth_x << ", " << row.truth_y << ")";
    EXPECT_EQ(pose[2], 0.0);
    EXPECT_EQ(pose[3], 1.0);
    ++compared;
  }
  EXPECT_GT(compared, 0U);
}

TEST_F(Ros2OverDds, RangesArriveOncePerWorldStepAndAgreeWithTheTruth) {
  ASSERT_TRUE(swarmloc::testing::completed_run(run().exit_code)) << run().output;
  const auto& arrays = run().reader.ranges;
  ASSERT_EQ(arrays.size(), static_cast<std::size_t>(kRos2Steps));
  const auto& truth = run().reader.truth;
  for (std::size_t k = 0; k < arrays.size(); ++k) {
    EXPECT_EQ(arrays[k].step, static_cast<std::int64_t>(k));
    EXPECT_EQ(arrays[k].stamp_ns, static_cast<std::int64_t>(static_cast<double>(k) / kRos2RateHz * 1e9));
    EXPECT_FALSE(arrays[k].ranges.empty());
    for (const auto& r : arrays[k].ranges) {
      ASSERT_TRUE(r.agent >= 0 && r.agent < kRos2Agents && r.peer >= 0 && r.peer < kRos2Agents &&
                  r.agent != r.peer);
      ASSERT_LT(k, truth.size());
      const auto& a = truth[k].poses.at(static_cast<std::size_t>(r.agent));
      const auto& b = truth[k].poses.at(static_cast<std::size_t>(r.peer));
      EXPECT_GT(r.std_m, 0.0);
      EXPECT_LT(std::abs(r.range_m - std::hypot(a[0] - b[0], a[1] - b[1])), 6.0 * r.std_m);
    }
  }
}

TEST_F(Ros2OverDds, DcpsPublicationShowsTheRos2TypeNamesOnRtSwarmlocTopics) {
  ASSERT_TRUE(swarmloc::testing::completed_run(run().exit_code)) << run().output;
  std::set<std::pair<std::string, std::string>> expected{
      {"rt/swarmloc/truth", "geometry_msgs::msg::dds_::PoseArray_"},
      {"rt/swarmloc/ranges", "swarmloc_msgs::msg::dds_::RangeArray_"}};
  for (int agent = 0; agent < kRos2Agents; ++agent) {
    expected.emplace("rt/swarmloc/agent_" + std::to_string(agent) + "/pose",
                     "geometry_msgs::msg::dds_::PoseWithCovarianceStamped_");
  }
  std::set<std::pair<std::string, std::string>> ros_topics;
  for (const auto& publication : run().reader.publications) {
    if (publication.first.rfind("rt/", 0) == 0) ros_topics.insert(publication);
  }
  EXPECT_EQ(ros_topics, expected);
}

// A 3-D world (docs/design.md §3.1): every pose carries its z and z's row of the covariance, and the truth
// array the truth's z.
TEST(Ros2In3d, PosesAndTruthCarryTheirZ) {
  constexpr int kAgents = 30;
  const Ros2Run run = run_with_ros2_reader("ros2-3d", 73, kAgents, " --set dds.ros2=true", "default3d");
  ASSERT_TRUE(swarmloc::testing::completed_run(run.exit_code)) << run.output;
  const auto rows = read_ros2_estimates_csv(run.dir / "estimates.csv");
  std::size_t matched = 0;
  for (const auto& row : rows) {
    if (!row.valid) continue;
    const auto found = run.reader.poses.find(row.agent);
    ASSERT_NE(found, run.reader.poses.end()) << "no pose from agent " << row.agent;
    const bool carried =
        std::any_of(found->second.begin(), found->second.end(), [&row](const Ros2Pose& pose) {
          return ros2_near(pose.values[0], row.x) && ros2_near(pose.values[1], row.y) &&
                 ros2_near(pose.values[2], row.z) && ros2_near(pose.covariance(2, 2), row.cov_zz) &&
                 pose.covariance(2, 0) == pose.covariance(0, 2);
        });
    EXPECT_TRUE(carried) << "agent " << row.agent << " step " << row.step << ": z " << row.z;
    if (carried) ++matched;
  }
  EXPECT_GT(matched, 0U);
  std::map<std::int64_t, const Ros2TruthArray*> by_step;
  for (const auto& array : run.reader.truth) {
    by_step.emplace(std::llround(static_cast<double>(array.stamp_ns) * 1e-9 * kRos2RateHz), &array);
  }
  std::size_t compared = 0;
  for (const auto& row : rows) {
    const auto found = by_step.find(row.step);
    if (found == by_step.end()) continue;
    EXPECT_TRUE(ros2_near(found->second->poses.at(static_cast<std::size_t>(row.agent))[2], row.truth_z))
        << "step " << row.step << " agent " << row.agent;
    ++compared;
  }
  EXPECT_GT(compared, 0U);
}

TEST(Ros2OffByDefault, NoRosTopicIsPublishedWithoutTheKey) {
  const Ros2Run run = run_with_ros2_reader("ros2-off", 72, 5, "");
  ASSERT_TRUE(swarmloc::testing::completed_run(run.exit_code)) << run.output;
  int ros_topics = 0, swarmloc_estimate_writers = 0;
  for (const auto& [topic, type] : run.reader.publications) {
    ros_topics += topic.rfind("rt/", 0) == 0 ? 1 : 0;
    swarmloc_estimate_writers += topic == "swarmloc_estimate" ? 1 : 0;
  }
  EXPECT_EQ(ros_topics, 0);
  // The reader did discover the run (so the absence of rt/ topics means something).
  EXPECT_EQ(swarmloc_estimate_writers, 5) << run.reader_stderr;
}

TEST(Ros2BadInput, InvalidRos2ValueExitsTwoNamingTheKey) {
  const auto dir = fresh_directory("ros2-bad");
  const auto result = run_command(kRos2Binary + " run " + kRos2Source + "/scenarios/ieif.yaml -q --out " +
                                  dir.string() + " --set dds.ros2=maybe");
  EXPECT_EQ(result.exit_code, 2) << result.output;
  EXPECT_NE(result.output.find("dds.ros2"), std::string::npos) << result.output;
}

}  // namespace
}  // namespace ros2_test
