// A simulated 3-D world end to end (docs/design.md §3.1): every agent reports its z, the run is scored in
// space against the 3-D bound and optimum, and the run directory carries the third coordinate.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/rundir/run_record.hpp"
#include "swarmloc/sim/simulator.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::sim {
namespace {

const std::string kSpatialScenario = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/default3d.yaml";

std::string first_line_of(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  return line;
}

TEST(Simulated3d, ScoresInSpaceAgainstTheSpatialBoundAndOptimum) {
  const auto s = config::load_scenario(kSpatialScenario, {"run.steps=60"});
  const rundir::RunRecord record = run_simulation(s);
  const world::World world = world::build_world(s);
  const auto* last = record.final_metrics();
  ASSERT_NE(last, nullptr);
  EXPECT_EQ(last->errors.scored, world.size() - world.anchor_count());
  // The final rows: each agent's z and its distance from the truth in space.
  double squared = 0.0;
  int rows = 0;
  for (const auto& row : record.estimates) {
    if (row.step != last->step || world.is_anchor[static_cast<std::size_t>(row.agent)]) continue;
    ASSERT_TRUE(row.estimate.altitude.has_value()) << row.agent;
    EXPECT_EQ(row.truth_z_m, world.altitude[static_cast<std::size_t>(row.agent)]);
    const Vec3 error = join(row.estimate.mean_m, row.estimate.altitude->z_m) - world.position3(row.agent);
    EXPECT_NEAR(row.error_m(), error.norm(), 1e-12);
    squared += error.squaredNorm();
    ++rows;
  }
  ASSERT_EQ(rows, last->errors.scored);
  EXPECT_NEAR(last->errors.rmse_m, std::sqrt(squared / rows), 1e-12);
  const auto summary = rundir::summary_json(record);
  EXPECT_EQ(summary["dimensions"], 3);
  EXPECT_EQ(summary["optimum"]["kind"], "batch_ml");
  EXPECT_EQ(summary["bound"]["kind"], "crlb_static_accumulated");
  // The optimum of 60 steps of 0.1 m draws is centimetres off, as is its bound; both in space.
  const double optimum = summary["optimum"]["rmse_m"].get<double>();
  const double bound = summary["bound"]["rmse_m"].get<double>();
  EXPECT_GT(optimum, 0.3 * bound);
  EXPECT_LT(optimum, 3.0 * bound);
  EXPECT_LT(bound, 0.1);
}

TEST(Simulated3d, TheRunDirectoryCarriesTheThirdCoordinate) {
  const auto s = config::load_scenario(kSpatialScenario, {"run.steps=20"});
  const rundir::RunRecord record = run_simulation(s);
  const auto directory =
      std::filesystem::temp_directory_path() / ("swarmloc-3d-" + std::to_string(::getpid()));
  std::filesystem::remove_all(directory);
  rundir::write_run_directory(directory, record);
  EXPECT_EQ(
      first_line_of(directory / "estimates.csv"),
      "step,agent,x_m,y_m,cov_xx,cov_xy,cov_yy,valid,truth_x_m,truth_y_m,error_m,inconsistent,z_m,cov_xz,"
      "cov_yz,cov_zz,truth_z_m");
  // TUM lines: time x y z and a unit quaternion; the truth's z is the world's.
  const world::World world = world::build_world(s);
  std::istringstream truth_line(first_line_of(directory / "trajectories" / "agent_0_truth.tum"));
  double time = 0.0;
  double x = 0.0;
  double y = 0.0;
  double z = 0.0;
  truth_line >> time >> x >> y >> z;
  EXPECT_NEAR(z, world.altitude[0], 1e-9);
  // The plots' table carries z, and a side view (x against z) is drawn from it.
  std::ifstream positions(directory / "plots" / "final_positions.csv");
  std::string line;
  std::getline(positions, line);
  EXPECT_EQ(line, "agent,anchor,truth_x,truth_y,est_x,est_y,error_m,lost,truth_z,est_z,z_std");
  std::getline(positions, line);  // agent 0
  std::vector<std::string> cells;
  std::istringstream row(line);
  for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
  ASSERT_EQ(cells.size(), 11U) << line;
  EXPECT_NEAR(std::stod(cells[8]), world.altitude[0], 1e-6) << line;
  EXPECT_TRUE(std::filesystem::exists(directory / "plots" / "altitude.gp"));
  std::filesystem::remove_all(directory);
}

// The default 3-D world on its first three seeds, 300 steps in synchronous rounds: dml ends on the optimum of
// its own draws, with a covariance that covers its error (docs/algorithms.md §9.9, "The world's density").
TEST(Simulated3d, TheDefaultWorldEndsOnTheOptimumOfItsDraws) {
  for (const int seed : {1, 2, 3}) {
    const auto s = config::load_scenario(kSpatialScenario, {"seed=" + std::to_string(seed)});
    const auto summary = rundir::summary_json(run_simulation(s));
    const double efficiency = summary["efficiency"].get<double>();
    const double nees = summary["final"]["nees"].get<double>();
    EXPECT_LT(efficiency, 1.10) << "seed " << seed;
    EXPECT_GT(efficiency, 0.90) << "seed " << seed;
    EXPECT_LT(nees, 4.0) << "seed " << seed;
    EXPECT_EQ(summary["final"]["flagged_agents"], 0) << "seed " << seed;
    EXPECT_EQ(summary["final"]["scored_agents"], 22) << "seed " << seed;
  }
}

// The centralized filters in space (docs/algorithms.md §2.10): every agent's estimate has a z, the run is
// scored in space, and Khan et al.'s total MSE (every agent, anchors included) counts the z errors.
TEST(Simulated3d, TheCentralizedFiltersEstimateInSpace) {
  for (const std::string algorithm : {"ekf", "lbekf_vr", "lbekf_i"}) {
    const auto s = config::load_scenario(kSpatialScenario, {"algorithm.name=" + algorithm});
    const rundir::RunRecord record = run_simulation(s);
    const auto* last = record.final_metrics();
    ASSERT_NE(last, nullptr);
    double total = 0.0;
    for (const auto& row : record.estimates) {
      if (row.step != last->step) continue;
      ASSERT_TRUE(row.estimate.altitude.has_value()) << algorithm << " agent " << row.agent;
      total += row.error_m() * row.error_m();
    }
    const auto summary = rundir::summary_json(record);
    EXPECT_EQ(summary["dimensions"], 3);
    EXPECT_EQ(last->errors.scored, 22) << algorithm;
    EXPECT_NEAR(summary["final_total_mse_m2"].get<double>(), total, 1e-9 * total) << algorithm;
    // Their random-walk model forgets, so after 300 steps they end about 3x the static bound (the plane's
    // default world: 4.2-4.4x), with a covariance that covers the error.
    EXPECT_LT(last->errors.rmse_m, 4.0 * summary["bound"]["rmse_m"].get<double>()) << algorithm;
    EXPECT_GT(last->errors.nees, 0.3) << algorithm;
    EXPECT_LT(last->errors.nees, 2.5) << algorithm;
  }
}

// Drones that random-walk in space (docs/algorithms.md §1.3, the PCRB in D): the centralized EKF, whose
// process noise is the walk's, ends on the 3-D posterior CRB of each trial's trajectory with a NEES of 3, and
// on the final state of the MAP smoother of each trial's own data. Seeded, so the figures are fixed: 10
// trials, 100 steps: 0.958x the PCRB, 0.997x the smoother, NEES 2.88 when written.
TEST(Simulated3d, TheEkfTracksDronesWalkingInSpaceOnTheirPosteriorCrb) {
  const auto s =
      config::load_scenario(std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/drones3d.yaml", {"run.steps=100"});
  const MonteCarloResult result = run_monte_carlo(s, 10, 1);
  const MonteCarloStep& last = result.steps.back();
  const double ratio = std::sqrt(last.mse_mean) / last.bound_rmse_m;
  const double efficiency = std::sqrt(last.mse_mean) / last.optimum_rmse_m;
  std::printf(
      "3-D moving EKF: %.4f m against the PCRB %.4f m (%.3fx) and the smoother %.4f m (%.4fx), NEES %.2f\n",
      std::sqrt(last.mse_mean), last.bound_rmse_m, ratio, last.optimum_rmse_m, efficiency, last.nees_mean);
  EXPECT_GT(ratio, 0.9);
  EXPECT_LT(ratio, 1.1);
  // A Kalman filter's last estimate is the smoother's last state when the models are the world's.
  EXPECT_GT(efficiency, 0.98);
  EXPECT_LT(efficiency, 1.02);
  EXPECT_GT(last.nees_mean, 2.5);
  EXPECT_LT(last.nees_mean, 3.5);
}

}  // namespace
}  // namespace swarmloc::sim
