// Run-directory plots (data files, chi-square NEES band, covariance ellipses) and TUM trajectory export.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "swarmloc/rundir/plots.hpp"
#include "swarmloc/rundir/tum_export.hpp"
#include "swarmloc/sim/simulator.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::rundir {
namespace {

namespace fs = std::filesystem;

config::Scenario tiny_scenario() {
  config::Scenario s;
  s.seed = 11;
  s.world.agents = 12;
  s.world.anchors = 4;
  s.world.area_m = 20.0;
  s.world.comm_radius_m = 12.0;
  s.noise.range_std_m = 0.1;
  s.run.steps = 30;
  return s;
}

/// A fresh, empty temporary directory removed at the end of the test.
class PlotsTempDir {
 public:
  explicit PlotsTempDir(const std::string& name)
      : path_(fs::temp_directory_path() / (name + "-" + std::to_string(::getpid()))) {
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~PlotsTempDir() { fs::remove_all(path_); }
  PlotsTempDir(const PlotsTempDir&) = delete;
  PlotsTempDir& operator=(const PlotsTempDir&) = delete;
  [[nodiscard]] const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

struct TumPose {
  double t, x, y, z, qx, qy, qz, qw;
};

/// Reads a TUM file; every non-comment line must have exactly 8 numeric columns.
std::vector<TumPose> read_tum(const fs::path& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  std::vector<TumPose> poses;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::vector<double> values;
    std::string token;
    while (fields >> token) values.push_back(std::stod(token));
    EXPECT_EQ(values.size(), 8u) << path << ": " << line;
    if (values.size() != 8u) continue;
    poses.push_back({values[0], values[1], values[2], values[3], values[4], values[5], values[6], values[7]});
  }
  return poses;
}

void expect_well_formed(const std::vector<TumPose>& poses, const fs::path& path) {
  ASSERT_FALSE(poses.empty()) << path;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const auto& p = poses[k];
    EXPECT_TRUE(std::isfinite(p.t) && std::isfinite(p.x) && std::isfinite(p.y)) << path;
    EXPECT_DOUBLE_EQ(p.z, 0.0);
    EXPECT_NEAR(std::sqrt(p.qx * p.qx + p.qy * p.qy + p.qz * p.qz + p.qw * p.qw), 1.0, 1e-12) << path;
    if (k > 0) {
      EXPECT_GT(p.t, poses[k - 1].t) << path << " line " << k;
    }
  }
}

bool gnuplot_on_path() { return std::system("command -v gnuplot >/dev/null 2>&1") == 0; }

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

TEST(RunDirectory, WritesTumTrajectoriesAndPlotData) {
  const auto scenario = tiny_scenario();
  const auto record = sim::run_simulation(scenario);
  ASSERT_FALSE(record.estimates.empty());
  const PlotsTempDir dir("swarmloc-plots-tum");
  write_run_directory(dir.path(), record);

  // TUM: one estimate and one truth file per agent; the estimate's last pose is the run's final estimate.
  const auto last_step = record.estimates.back().step;
  int final_rows = 0;
  for (const auto& row : record.estimates) {
    if (row.step != last_step) continue;
    ++final_rows;
    const auto stem = dir.path() / "trajectories" / ("agent_" + std::to_string(row.agent));
    const auto estimate_path = fs::path(stem.string() + ".tum");
    const auto truth_path = fs::path(stem.string() + "_truth.tum");
    const auto estimate = read_tum(estimate_path);
    const auto truth = read_tum(truth_path);
    expect_well_formed(estimate, estimate_path);
    expect_well_formed(truth, truth_path);
    ASSERT_EQ(estimate.size(), static_cast<std::size_t>(scenario.run.steps));
    ASSERT_EQ(truth.size(), estimate.size());
    EXPECT_NEAR(estimate.back().x, row.estimate.mean_m.x(), 1e-9);
    EXPECT_NEAR(estimate.back().y, row.estimate.mean_m.y(), 1e-9);
    EXPECT_NEAR(truth.back().x, row.truth.x(), 1e-9);
    EXPECT_NEAR(truth.back().y, row.truth.y(), 1e-9);
    EXPECT_NEAR(estimate.back().t, record.metrics.back().time_s, 1e-9);
    EXPECT_DOUBLE_EQ(estimate.front().t, truth.front().t);
  }
  EXPECT_EQ(final_rows, 12);

  // Plot scripts and data files always exist.
  const auto plots = dir.path() / "plots";
  for (const char* name :
       {"plots.gp", "error.gp", "nees.gp", "positions.gp", "error_histogram.gp", "nees_band.csv",
        "final_positions.csv", "ellipses.csv", "link_segments.csv", "error_histogram.csv"}) {
    EXPECT_TRUE(fs::exists(plots / name)) << name;
    EXPECT_GT(fs::file_size(plots / name), 0u) << name;
  }
  // The histogram counts every non-anchor agent once.
  {
    std::ifstream in(plots / "error_histogram.csv");
    std::string line;
    std::getline(in, line);
    int total = 0;
    while (std::getline(in, line)) total += std::stoi(line.substr(line.rfind(',') + 1));
    EXPECT_EQ(total, 12 - 4);
  }
  // Every link segment carries a delivered fraction in [0, 1].
  {
    std::ifstream in(plots / "link_segments.csv");
    std::string line;
    int links = 0;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::vector<double> v;
      std::stringstream fields(line);
      std::string cell;
      while (std::getline(fields, cell, ',')) v.push_back(std::stod(cell));
      ASSERT_EQ(v.size(), 7u);
      EXPECT_GE(v[4], 0.0);
      EXPECT_LE(v[4], 1.0);
      ++links;
    }
    EXPECT_GT(links, 0);
  }

  if (!gnuplot_on_path()) GTEST_SKIP() << "gnuplot not on PATH: PNGs not checked";
  for (const char* name : {"error.png", "nees.png", "positions.png", "error_histogram.png"}) {
    EXPECT_TRUE(fs::exists(plots / name)) << name;
    if (fs::exists(plots / name)) {
      EXPECT_GT(fs::file_size(plots / name), 1000u) << name;
    }
  }
}

// Recorded data has instants without ground truth (MRCLAM) and an estimator can diverge: neither has an
// error to bin. Before 2026-12-03 a truth gap put NaN into the histogram: every agent in one 1 mm bin and
// "mean nan m" in the title of `replay --mrclam`'s plot.
TEST(RunDirectory, TheErrorHistogramBinsOnlyErrorsThatExist) {
  const auto scenario = tiny_scenario();
  const world::World world = world::build_world(scenario);
  auto record = sim::run_simulation(scenario);
  const auto last_step = record.estimates.back().step;
  int changed = 0;
  for (auto& row : record.estimates) {
    if (row.step != last_step || world.is_anchor[static_cast<std::size_t>(row.agent)] || changed == 2)
      continue;
    if (changed++ == 0) {
      row.truth.x() = std::numeric_limits<double>::quiet_NaN();
    } else {
      row.estimate.mean_m.y() = std::numeric_limits<double>::infinity();
    }
  }
  ASSERT_EQ(changed, 2);
  const PlotsTempDir dir("swarmloc-plots-gaps");
  write_run_directory(dir.path(), record);
  std::ifstream in(dir.path() / "plots" / "error_histogram.csv");
  std::string line;
  std::getline(in, line);
  int total = 0;
  while (std::getline(in, line)) total += std::stoi(line.substr(line.rfind(',') + 1));
  EXPECT_EQ(total, 12 - 4 - 2);
  std::ifstream script_in(dir.path() / "plots" / "error_histogram.gp");
  std::stringstream script;
  script << script_in.rdbuf();
  EXPECT_EQ(script.str().find("nan"), std::string::npos) << script.str();
  EXPECT_NE(script.str().find("final error of 6 non-anchor agents"), std::string::npos) << script.str();
}

TEST(TumExport, WritesNothingWithoutEstimates) {
  RunRecord record;
  record.scenario = tiny_scenario();
  const PlotsTempDir dir("swarmloc-tum-empty");
  EXPECT_EQ(write_tum_trajectories(dir.path(), record), 0);
  EXPECT_FALSE(fs::exists(dir.path() / "trajectories"));
}

}  // namespace
}  // namespace swarmloc::rundir
