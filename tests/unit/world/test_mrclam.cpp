// UTIAS MRCLAM as a recorded world: the loader on a small hand-made dataset. The real Dataset 6 in the
// simulator: tests/unit/sim/test_simulated_mrclam.cpp.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "dataset_paths.hpp"
#include "swarmloc/world/mrclam.hpp"

namespace swarmloc::world {
namespace {

namespace fs = std::filesystem;

/// A five-robot dataset: robot r starts at (r, 0) facing +x, drives at 0.5 m/s from t = 100.05 on;
/// landmark 6 (barcode 60) at (10, 0); robot 5's groundtruth ends early (at t = 101); robot 3's has a
/// gap of 0.6 s (101.2 to 101.8) and robot 2's one of 0.3 s (101.2 to 101.5).
class TinyDataset {
 public:
  TinyDataset() : dir_(fs::temp_directory_path() / ("mrclam-" + std::to_string(::getpid()))) {
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    write("Barcodes", "# Subject Barcode\n1 11\n2 12\n3 13\n4 14\n5 15\n6 60\n");
    write("Landmark_Groundtruth", "6 10.0 0.0 0.001 0.002\n");
    for (int r = 1; r <= 5; ++r) {
      const std::string robot = "Robot" + std::to_string(r) + "_";
      std::string groundtruth;
      const double end = r == 5 ? 101.0 : 102.0;
      for (double t = 100.0; t <= end + 1e-9; t += 0.01) {
        const bool lost = (r == 3 && t > 101.2 + 1e-9 && t < 101.8 - 1e-9) ||
                          (r == 2 && t > 101.2 + 1e-9 && t < 101.5 - 1e-9);
        if (lost) continue;
        const double x = r + 0.5 * std::max(0.0, t - 100.05);
        groundtruth += std::to_string(t) + " " + std::to_string(x) + " 0 0\n";
      }
      write(robot + "Groundtruth", groundtruth);
      write(robot + "Odometry", "100.05 0.5 0\n101.05 0.5 0\n102.0 0.5 0\n");
      // Robot r sees the landmark at t = 100.12 and robot (r mod 5) + 1 at 100.31; one unknown barcode.
      write(robot + "Measurement", "100.12 60 " + std::to_string(10.0 - r - 0.035) + " 0.0\n100.31 " +
                                       std::to_string(10 + r % 5 + 1) + " 1.0 0.0\n100.5 99 1.0 0.0\n");
    }
  }
  ~TinyDataset() { fs::remove_all(dir_); }
  TinyDataset(const TinyDataset&) = delete;
  TinyDataset& operator=(const TinyDataset&) = delete;
  [[nodiscard]] const fs::path& dir() const { return dir_; }
  void write(const std::string& name, const std::string& text) const {
    std::ofstream(dir_ / (name + ".dat")) << "# UTIAS-style header\n" << text;
  }

 private:
  fs::path dir_;
};

using testing::mrclam_scenario;

TEST(Mrclam, LoaderMapsBarcodesCountsUnknownOnesAndFindsTheCommonWindow) {
  const TinyDataset data;
  const auto loaded = load_mrclam(data.dir());
  ASSERT_EQ(loaded.robots.size(), 5U);
  EXPECT_EQ(loaded.unknown_barcodes, 5);  // barcode 99, once per robot
  EXPECT_NEAR(loaded.start_time_s, 100.0, 1e-9);
  EXPECT_NEAR(loaded.end_time_s, 102.0, 1e-9);  // earliest last odometry row
  ASSERT_EQ(loaded.robots[0].measurements.size(), 2U);
  EXPECT_EQ(loaded.robots[0].measurements[0].subject, 6);
  EXPECT_EQ(loaded.robots[0].measurements[1].subject, 2);
  EXPECT_EQ(loaded.robots[4].measurements[1].subject, 1);
}

TEST(Mrclam, StepsCarryTheirOdometryAndMeasurementsAndTruthEndsWithTheGroundtruth) {
  const TinyDataset data;
  const auto world = build_world(mrclam_scenario(data.dir(), 20));
  ASSERT_TRUE(world.recorded);
  EXPECT_EQ(world.recorded->steps(), 21);  // 2 s of 0.1 s steps, both ends included
  EXPECT_EQ(world.size(), 5);
  EXPECT_NEAR(world.initial_guess[2].x(), 3.0, 1e-9);
  EXPECT_EQ(world.neighbours[0], (std::vector<AgentId>{1, 2, 3, 4}));

  // Step 1 covers (100.0, 100.1]: 0.05 s of driving (the first odometry row is at 100.05), and the
  // landmark sighting at 100.12 belongs to step 2, the robot sighting at 100.31 to step 4.
  const auto step1 = world.recorded->batch(0, 1);
  ASSERT_TRUE(step1.odometry.has_value());
  double driven = 0.0;
  for (const auto& segment : step1.odometry->segments) driven += segment.v_mps * segment.dt_s;
  EXPECT_NEAR(driven, 0.025, 1e-9);
  EXPECT_TRUE(step1.range_bearings.empty());
  const auto step2 = world.recorded->batch(0, 2);
  ASSERT_EQ(step2.range_bearings.size(), 1U);
  EXPECT_TRUE(step2.range_bearings[0].landmark);
  EXPECT_NEAR(step2.range_bearings[0].landmark_m.x(), 10.0, 1e-12);
  EXPECT_NEAR(step2.range_bearings[0].landmark_cov(1, 1), 4e-6, 1e-12);
  const auto step4 = world.recorded->batch(0, 4);
  ASSERT_EQ(step4.range_bearings.size(), 1U);
  EXPECT_FALSE(step4.range_bearings[0].landmark);
  EXPECT_EQ(step4.range_bearings[0].peer, 1);

  // Every step's odometry adds up to the step length once driving started.
  double total = 0.0;
  for (std::int64_t k = 1; k <= 20; ++k) {
    const auto batch = world.recorded->batch(3, k);
    for (const auto& segment : batch.odometry->segments) total += segment.dt_s;
  }
  EXPECT_NEAR(total, 2.0 - 0.05, 1e-9);

  EXPECT_NEAR(world.recorded->truth(10)[0].x(), 1.0 + 0.5 * 0.95, 1e-6);
  EXPECT_FALSE(world.recorded->truth(15)[4].allFinite());  // robot 5's groundtruth ended at 101 s
  EXPECT_TRUE(world.recorded->truth(15)[3].allFinite());
}

TEST(Mrclam, TheCommandLagShiftsTheOdometryOfEveryStep) {
  const TinyDataset data;
  auto scenario = mrclam_scenario(data.dir(), 20);
  scenario.noise.odometry_lag_s = 0.1;
  const auto world = build_world(scenario);
  ASSERT_TRUE(world.recorded);
  // Driving is commanded from 100.05 s, so the robot moves from 100.15 s: not at all in step 1
  // (100.0, 100.1], for 0.05 s in step 2.
  const auto driven = [&](std::int64_t step) {
    double distance = 0.0;
    const auto batch = world.recorded->batch(0, step);
    for (const auto& segment : batch.odometry->segments) distance += segment.v_mps * segment.dt_s;
    return distance;
  };
  EXPECT_NEAR(driven(1), 0.0, 1e-12);
  EXPECT_NEAR(driven(2), 0.025, 1e-9);
  EXPECT_NEAR(driven(3), 0.05, 1e-9);
  // The sightings keep their own times: the landmark sighting at 100.12 s is still step 2's.
  EXPECT_EQ(world.recorded->batch(0, 2).range_bearings.size(), 1U);
}

TEST(Mrclam, TruthInsideALongGapInTheGroundtruthIsUnknownAndAShortGapIsInterpolated) {
  const TinyDataset data;
  const auto world = build_world(mrclam_scenario(data.dir(), 20));
  ASSERT_TRUE(world.recorded);
  // Robot 3 (agent 2) is lost from 101.2 to 101.8 s: steps 13 to 17 have no truth, steps 12 and 19 do.
  EXPECT_TRUE(world.recorded->truth(12)[2].allFinite());
  for (std::int64_t step = 13; step <= 17; ++step) {
    EXPECT_FALSE(world.recorded->truth(step)[2].allFinite()) << step;
    EXPECT_TRUE(std::isnan(world.recorded->truth_heading(2, step))) << step;
  }
  EXPECT_NEAR(world.recorded->truth(19)[2].x(), 3.0 + 0.5 * 1.85, 1e-6);
  // Robot 2 (agent 1) is lost for 0.3 s: interpolated across the gap.
  EXPECT_NEAR(world.recorded->truth(14)[1].x(), 2.0 + 0.5 * 1.35, 1e-6);
}

TEST(Mrclam, EachSightingGetsTheRangeStdOfTheNoiseModelAtItsMeasuredRange) {
  const TinyDataset data;
  auto scenario = mrclam_scenario(data.dir(), 20);
  scenario.noise.range_std_m = 0.05;
  scenario.noise.range_factor = 0.03;
  const double landmark_range = 10.0 - 1 - 0.035;  // robot 1's sighting of the landmark (step 2)
  const double robot_range = 1.0;                  // its sighting of robot 2 (step 4)
  const std::vector<std::pair<config::RangeNoise, std::array<double, 2>>> models{
      {config::RangeNoise::kAdditive, {0.05, 0.05}},
      {config::RangeNoise::kProportional, {0.03 * landmark_range, 0.03 * robot_range}},
      {config::RangeNoise::kAffine, {0.05 + 0.03 * landmark_range, 0.05 + 0.03 * robot_range}}};
  for (const auto& [model, expected] : models) {
    scenario.noise.range_model = model;
    const auto world = build_world(scenario);
    const auto landmark = world.recorded->batch(0, 2).range_bearings;
    const auto robot = world.recorded->batch(0, 4).range_bearings;
    ASSERT_EQ(landmark.size(), 1U);
    ASSERT_EQ(robot.size(), 1U);
    EXPECT_NEAR(landmark[0].range_std_m, expected[0], 1e-9);
    EXPECT_NEAR(robot[0].range_std_m, expected[1], 1e-9);
  }
}

TEST(Mrclam, TheCamerasRangeBiasIsRemovedFromEverySighting) {
  // The tiny dataset's sightings are straight ahead (bearing 0): only the constant term applies there, and
  // the robot sighting loses the robots' offset too. The std is the model's at the corrected range.
  const TinyDataset data;
  auto scenario = mrclam_scenario(data.dir(), 20);
  scenario.noise.range_bias_m = 0.1;
  scenario.noise.range_bias_per_rad = 0.3;
  scenario.noise.range_bias_per_rad2 = -1.5;
  scenario.noise.robot_range_bias_m = 0.04;
  scenario.noise.range_model = config::RangeNoise::kAffine;
  scenario.noise.range_std_m = 0.05;
  scenario.noise.range_factor = 0.01;
  const auto world = build_world(scenario);
  const auto landmark = world.recorded->batch(0, 2).range_bearings;
  const auto robot = world.recorded->batch(0, 4).range_bearings;
  ASSERT_EQ(landmark.size(), 1U);
  ASSERT_EQ(robot.size(), 1U);
  const double landmark_range = 10.0 - 1 - 0.035 - 0.1;
  EXPECT_NEAR(landmark[0].range_m, landmark_range, 1e-6);
  EXPECT_NEAR(landmark[0].range_std_m, 0.05 + 0.01 * landmark_range, 1e-6);
  EXPECT_NEAR(robot[0].range_m, 1.0 - 0.1 - 0.04, 1e-6);
}

TEST(Mrclam, BadDataIsAClearErrorNamingTheFileAndLine) {
  const TinyDataset data;
  data.write("Robot3_Odometry", "100.05 0.5 0\n101.0 nan 0\n");
  try {
    (void)load_mrclam(data.dir());
    FAIL() << "expected an error";
  } catch (const config::ScenarioError& error) {
    EXPECT_NE(std::string(error.what()).find("Robot3_Odometry line 3"), std::string::npos) << error.what();
  }
  fs::remove(data.dir() / "Barcodes.dat");
  EXPECT_THROW((void)load_mrclam(data.dir()), config::ScenarioError);
  EXPECT_THROW((void)build_world(mrclam_scenario(data.dir() / "missing", 5)), config::ScenarioError);
}

TEST(Mrclam, RunningPastTheDataIsRefused) {
  const TinyDataset data;
  EXPECT_THROW((void)build_world(mrclam_scenario(data.dir(), 22)), config::ScenarioError);
}

}  // namespace
}  // namespace swarmloc::world
