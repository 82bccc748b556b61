// Run-directory plots (chi-square NEES band, covariance ellipses) and TUM trajectory export. A simulated
// run's plot data and TUM trajectories: tests/unit/sim/test_simulated_run_directory.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "process_helpers.hpp"
#include "run_report_fixtures.hpp"
#include "swarmloc/rundir/plots.hpp"
#include "swarmloc/rundir/tum_export.hpp"

namespace swarmloc::rundir {
namespace {

namespace fs = std::filesystem;

using testing::TempDir;
using testing::twelve_agent_scenario;

TEST(ChiSquare, WilsonHilfertyMatchesTabulatedQuantiles) {
  EXPECT_NEAR(normal_quantile(0.975), 1.959964, 1e-6);
  EXPECT_NEAR(normal_quantile(0.025), -1.959964, 1e-6);
  EXPECT_NEAR(normal_quantile(0.001), -3.090232, 1e-6);
  // Tabulated chi-square quantiles; Wilson–Hilferty is within 2 % for these.
  EXPECT_NEAR(chi_square_quantile(0.975, 20.0), 34.17, 0.02 * 34.17);
  EXPECT_NEAR(chi_square_quantile(0.025, 20.0), 9.59, 0.02 * 9.59);
  EXPECT_NEAR(chi_square_quantile(0.975, 60.0), 83.30, 0.02 * 83.30);
  EXPECT_NEAR(chi_square_quantile(0.025, 60.0), 40.48, 0.02 * 40.48);
  EXPECT_NEAR(chi_square_quantile(0.95, 2.0), kChiSquare2Dof95, 0.02 * kChiSquare2Dof95);
}

TEST(ChiSquare, NeesBandOfTheMeanOfNAgents) {
  // n = 10 agents, 2 dof each: [χ²_20(0.025), χ²_20(0.975)] / 10.
  const auto ten = nees_band(10);
  EXPECT_NEAR(ten.lower, 0.959, 0.02 * 0.959);
  EXPECT_NEAR(ten.upper, 3.417, 0.02 * 3.417);
  // The band brackets the expected value 2 and narrows around it as n grows.
  double previous_width = ten.upper - ten.lower;
  for (int n : {30, 100, 1000, 10000}) {
    const auto band = nees_band(n);
    EXPECT_LT(band.lower, 2.0) << n;
    EXPECT_GT(band.upper, 2.0) << n;
    EXPECT_LT(band.upper - band.lower, previous_width) << n;
    previous_width = band.upper - band.lower;
  }
  EXPECT_NEAR(nees_band(10000).lower, 2.0, 0.06);
  EXPECT_NEAR(nees_band(10000).upper, 2.0, 0.06);
  EXPECT_TRUE(std::isnan(nees_band(0).lower));
  // A 3-D world: 3 degrees of freedom per agent.
  EXPECT_NEAR(nees_band(10000, 0.95, 3).lower, 3.0, 0.07);
  EXPECT_NEAR(nees_band(10000, 0.95, 3).upper, 3.0, 0.07);
}

TEST(CovarianceEllipse, PointsLieOnTheChiSquareContour) {
  const Vec2 mean(3.0, -1.0);
  Mat2 cov;
  cov << 0.5, 0.2, 0.2, 0.3;
  const auto curve = covariance_ellipse(mean, cov);
  ASSERT_EQ(curve.size(), 65u);
  EXPECT_TRUE(curve.front().isApprox(curve.back()));
  const Mat2 info = cov.inverse();
  for (const auto& p : curve) {
    const Vec2 d = p - mean;
    EXPECT_NEAR(d.dot(info * d), kChiSquare2Dof95, 1e-9);
  }
  Mat2 singular;
  singular << 1.0, 1.0, 1.0, 1.0;
  EXPECT_TRUE(covariance_ellipse(mean, singular).empty());
}

TEST(TumExport, WritesNothingWithoutEstimates) {
  RunRecord record;
  record.scenario = twelve_agent_scenario();
  const TempDir dir("tum-empty");
  EXPECT_EQ(write_tum_trajectories(dir.path(), record), 0);
  EXPECT_FALSE(fs::exists(dir.path() / "trajectories"));
}

}  // namespace
}  // namespace swarmloc::rundir
