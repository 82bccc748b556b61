// The real UTIAS MRCLAM Dataset 6 in the simulator (skipped with a message when the dataset is absent;
// tests/support/dataset_paths.hpp). The loader: tests/unit/world/test_mrclam.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "dataset_paths.hpp"
#include "swarmloc/sim/simulator.hpp"
#include "swarmloc/world/mrclam.hpp"

namespace swarmloc::sim {
namespace {

/// The whole of Dataset 6 in the simulator with the `replay --mrclam` noise model: the distributed
/// filter and the centralized EKF beat dead reckoning by at least 5×.
TEST(Mrclam, Dataset6DistributedAndCentralizedFiltersBeatDeadReckoningFiveTimes) {
  const auto dir = testing::mrclam_dataset6(SWARMLOC_SOURCE_DIR);
  if (dir.empty() || !std::filesystem::exists(dir)) {
    GTEST_SKIP()
        << "UTIAS MRCLAM Dataset 6 not found (looked for shared/data/utias-mrclam/MRCLAM_Dataset6 beside "
        << SWARMLOC_SOURCE_DIR << " and its parents; set SWARMLOC_MRCLAM_DIR to the dataset directory)";
  }
  auto s = testing::mrclam_scenario(dir, 9000);
  s.algorithm.kalman.initial_std_m = 0.05;
  s.algorithm.pose.initial_heading_std_rad = 0.05;
  s.algorithm.pose.range_bearing_gate_chi2 = 13.8;
  s.noise.range_std_m = 0.3;
  s.noise.bearing_std_rad = 0.1;
  const auto world = world::build_world(s);
  ASSERT_EQ(world.recorded->steps(), 9000);  // 900 s of data
  const auto baselines = world::mrclam_baselines(s, world);
  SimOptions options;
  options.record_estimates = false;
  const auto record = run_simulation(s, options);
  double squared = 0.0;
  int scored = 0;
  for (const auto& m : record.metrics) {
    if (m.errors.scored == 0) continue;
    squared += m.errors.rmse_m * m.errors.rmse_m;
    ++scored;
  }
  const double distributed = std::sqrt(squared / scored);
  std::printf("Dataset 6 RMSE over the run: dead reckoning %.4f m, centralized EKF %.4f m, pose_ekf %.4f m\n",
              baselines.dead_reckoning.rmse_m, baselines.centralized_ekf.rmse_m, distributed);
  EXPECT_GT(baselines.dead_reckoning.rmse_m, 1.0);
  EXPECT_LT(5.0 * distributed, baselines.dead_reckoning.rmse_m);
  EXPECT_LT(5.0 * baselines.centralized_ekf.rmse_m, baselines.dead_reckoning.rmse_m);
  EXPECT_LT(distributed, 0.4);
  EXPECT_LT(baselines.centralized_ekf.rmse_m, 0.3);
  // The batch smoother (the non-causal optimum of the same data) converges and beats the causal filter.
  ASSERT_TRUE(baselines.batch_smoother);
  EXPECT_TRUE(baselines.batch_smoother->converged);
  EXPECT_LT(baselines.batch_smoother->rmse_m, 0.9 * baselines.centralized_ekf.rmse_m);
  EXPECT_TRUE(std::isfinite(baselines.batch_smoother->nees3));
  EXPECT_TRUE(std::isfinite(baselines.centralized_ekf.nees3));
}

}  // namespace
}  // namespace swarmloc::sim
