// The run directory of a simulated run (docs/robustness.md, "Outputs are complete or the run fails" and
// "Non-finite estimates"): a blocked or full target fails it and leaves no summary.json, summary.json is
// written last, whole PNGs even under a hostile --out, the plot data and TUM trajectories, a broken step
// marks the results not valid, and Monte Carlo's trials.csv names the trials that broke. The writers on
// their own: tests/unit/rundir.
#include <gtest/gtest.h>
#include <sys/mount.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "process_helpers.hpp"
#include "run_report_fixtures.hpp"
#include "swarmloc/rundir/external_program.hpp"
#include "swarmloc/rundir/plots.hpp"
#include "swarmloc/rundir/run_record.hpp"
#include "swarmloc/runtime/output_file.hpp"
#include "swarmloc/sim/simulator.hpp"
#include "swarmloc/world/metrics.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::sim {
namespace {

namespace fs = std::filesystem;

using testing::eight_agent_scenario;
using testing::estimates_near_truth;
using testing::first_non_anchor;
using testing::kInfinity;
using testing::read_text;
using testing::TempDir;
using testing::twelve_agent_scenario;
using testing::with_file_size_limit;

rundir::RunRecord small_record() {
  config::Scenario s;
  s.seed = 5;
  s.world.agents = 8;
  s.world.anchors = 3;
  s.world.area_m = 20.0;
  s.world.comm_radius_m = 12.0;
  s.run.steps = 10;
  return run_simulation(s);
}

/// A PNG ends with its IEND chunk.
bool whole_png(const fs::path& path) {
  const std::string bytes = read_text(path);
  const std::string iend("\0\0\0\0IEND\xae\x42\x60\x82", 12);
  return bytes.size() > iend.size() && bytes.compare(bytes.size() - iend.size(), iend.size(), iend) == 0;
}

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

// ---------------- a simulated run's run directory is complete or the run fails ----------------

TEST(OutputIntegrity, AnUnwritableTargetFailsTheRunDirectoryAndLeavesNoSummary) {
  const auto record = small_record();
  for (const std::string blocked : {"links.csv", "metrics.csv", "agents.csv", "plots"}) {
    const TempDir dir("blocked");
    // A directory where a file goes (or a file where plots/ goes): the open fails even for root.
    if (blocked == "plots") {
      runtime::write_text_file(dir.path() / blocked, "not a directory\n");
    } else {
      fs::create_directories(dir.path() / blocked);
    }
    try {
      rundir::write_run_directory(dir.path(), record);
      ADD_FAILURE() << "write_run_directory succeeded with " << blocked << " blocked";
    } catch (const runtime::OutputError& error) {
      EXPECT_NE(std::string(error.what()).find(blocked), std::string::npos) << error.what();
    }
    EXPECT_FALSE(fs::exists(dir.path() / "summary.json")) << blocked;
  }
}

TEST(OutputIntegrity, LargeEstimatesPastAFileSizeLimitFailTheRunDirectory) {
  const auto record = small_record();
  const TempDir dir("fsize");
  // scenario.yaml (3 KB) and the small CSVs fit in 4 KiB; estimates.csv (80 rows, 7 KB) does not.
  const int code = with_file_size_limit(4 * 1024, [&] {
    try {
      rundir::write_run_directory(dir.path(), record);
    } catch (const runtime::OutputError& error) {
      return std::string(error.what()).find("estimates.csv") != std::string::npos ? 0 : 2;
    }
    return 1;
  });
  EXPECT_EQ(code, 0) << "1: no error; 2: the error named another file";
  EXPECT_FALSE(fs::exists(dir.path() / "summary.json"));
}

TEST(OutputIntegrity, ACompleteRunDirectoryEndsWithItsSummary) {
  const auto record = small_record();
  const TempDir dir("complete");
  rundir::write_run_directory(dir.path(), record);
  const auto summary_time = fs::last_write_time(dir.path() / "summary.json");
  for (const auto& entry : fs::recursive_directory_iterator(dir.path())) {
    if (entry.is_regular_file()) {
      EXPECT_LE(entry.last_write_time(), summary_time) << entry.path();
    }
  }
  EXPECT_FALSE(fs::exists(dir.path() / "summary.json.partial"));
}

TEST(Plots, AnOutPathWithQuotesSpacesAndShellCharactersGetsWholePngs) {
  if (!rundir::find_program("gnuplot")) GTEST_SKIP() << "gnuplot is not installed";
  const auto record = small_record();
  const TempDir dir("quotes");
  const auto out = dir.path() / "it's a $dir; `x` \"y\"";
  rundir::write_run_directory(out, record);
  for (const char* png : {"error.png", "nees.png", "positions.png", "error_histogram.png"}) {
    const auto path = out / "plots" / png;
    ASSERT_TRUE(fs::exists(path)) << path;
    EXPECT_GT(fs::file_size(path), 1000u) << path;
  }
  EXPECT_TRUE(fs::exists(out / "summary.json"));
}

TEST(Plots, APngThatDoesNotFitIsAFailedWrite) {
  if (!rundir::find_program("gnuplot")) GTEST_SKIP() << "gnuplot is not installed";
  const auto record = small_record();
  const TempDir complete("png-metrics");
  rundir::write_run_directory(complete.path(), record);  // the metrics.csv the scripts read
  const TempDir dir("png-full");
  // A tmpfs that holds metrics.csv, the plot data and scripts (the same files as in `complete`, in 4 KiB
  // pages) and 20 KiB more: gnuplot leaves a truncated error.png (about 45 KB), which must not pass for a
  // plot. Without mount rights: a file size limit (gnuplot inherits it).
  std::uintmax_t pages = 1;  // metrics.csv
  for (const auto& entry : fs::directory_iterator(complete.path() / "plots")) {
    if (entry.path().extension() != ".png") pages += (entry.file_size() + 4095) / 4096;
  }
  const std::string size = "size=" + std::to_string(pages * 4 + 20) + "k";
  if (::mount("swarmloc-test", dir.path().c_str(), "tmpfs", 0, size.c_str()) == 0) {
    fs::copy_file(complete.path() / "metrics.csv", dir.path() / "metrics.csv");
    std::string message;
    try {
      rundir::write_plots(dir.path(), record);
    } catch (const runtime::OutputError& error) {
      message = error.what();
    }
    // No truncated PNG stays behind to pass for a plot.
    for (const auto& entry : fs::directory_iterator(dir.path() / "plots")) {
      if (entry.path().extension() == ".png") {
        EXPECT_TRUE(whole_png(entry.path())) << entry.path();
      }
    }
    ::umount(dir.path().c_str());
    EXPECT_NE(message.find(".png"), std::string::npos) << "no failed write: '" << message << "'";
    EXPECT_NE(message.find(std::strerror(ENOSPC)), std::string::npos) << message;
    return;
  }
  fs::copy_file(complete.path() / "metrics.csv", dir.path() / "metrics.csv");
  const int code = with_file_size_limit(16 * 1024, [&] {
    try {
      rundir::write_plots(dir.path(), record);
    } catch (const runtime::OutputError& error) {
      const std::string message = error.what();
      return message.find(".png") != std::string::npos &&
                     message.find(std::strerror(EFBIG)) != std::string::npos
                 ? 0
                 : 2;
    }
    return 1;
  });
  EXPECT_EQ(code, 0) << "1: no error; 2: the error did not name a PNG and EFBIG";
}

// ---------------- plot data and TUM trajectories ----------------

TEST(RunDirectory, WritesTumTrajectoriesAndPlotData) {
  const auto scenario = twelve_agent_scenario();
  const auto record = run_simulation(scenario);
  ASSERT_FALSE(record.estimates.empty());
  const TempDir dir("plots-tum");
  rundir::write_run_directory(dir.path(), record);

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

  // optimum.csv: every agent's optimum at the final step; its unknowns' errors make the optimum's RMSE.
  {
    std::ifstream in(dir.path() / "optimum.csv");
    std::string line;
    std::getline(in, line);
    EXPECT_EQ(line, "agent,unknown,x_m,y_m,cov_xx,cov_xy,cov_yy,truth_x_m,truth_y_m,error_m");
    int rows = 0;
    int unknowns = 0;
    double squared = 0.0;
    while (std::getline(in, line)) {
      std::vector<double> cells;
      std::stringstream fields(line);
      for (std::string cell; std::getline(fields, cell, ',');) cells.push_back(std::stod(cell));
      ASSERT_EQ(cells.size(), 10U) << line;
      EXPECT_NEAR(cells[9], std::hypot(cells[2] - cells[7], cells[3] - cells[8]), 1e-6) << line;
      for (const auto& row : record.estimates) {
        if (row.step == last_step && row.agent == rows) {
          EXPECT_NEAR(cells[7], row.truth.x(), 1e-6) << line;
        }
      }
      if (cells[1] == 1.0) {
        ++unknowns;
        squared += cells[9] * cells[9];
        EXPECT_GT(cells[4] * cells[6] - cells[5] * cells[5], 0.0) << "covariance PD: " << line;
      }
      ++rows;
    }
    EXPECT_EQ(rows, 12);
    ASSERT_GT(unknowns, 0);
    EXPECT_NEAR(std::sqrt(squared / unknowns), record.optimum.points.back().rmse_m, 1e-6);
  }

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
  const auto scenario = twelve_agent_scenario();
  const world::World world = world::build_world(scenario);
  auto record = run_simulation(scenario);
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
  const TempDir dir("plots-gaps");
  rundir::write_run_directory(dir.path(), record);
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

// ---------------- non-finite estimates in the record and in trials.csv ----------------

TEST(NonFiniteEstimates, TheRunRecordSaysTheResultsAreNotValid) {
  const auto scenario = eight_agent_scenario();
  rundir::RunRecord record = run_simulation(scenario, SimOptions{});
  ASSERT_EQ(record.metrics.size(), 4U);
  EXPECT_EQ(rundir::non_finite_estimates(record).steps, 0U);
  EXPECT_EQ(rundir::result_table(record).find("NOT VALID"), std::string::npos);
  EXPECT_NE(rundir::result_table(record).find("agents scored at the final step"), std::string::npos);
  const double clean_whole = rundir::whole_run_error(record).rmse_m;
  ASSERT_TRUE(std::isfinite(clean_whole));

  const world::World world = world::build_world(scenario);
  auto estimates = estimates_near_truth(world);
  estimates[first_non_anchor(world)]->mean_m.y() = kInfinity;
  record.metrics[1].errors = world::score(world, estimates);  // one agent diverged at step 1, then recovered
  const auto broken = rundir::non_finite_estimates(record);
  EXPECT_EQ(broken.steps, 1U);
  EXPECT_EQ(broken.first_step, record.metrics[1].step);
  EXPECT_EQ(broken.most_agents, 1);
  EXPECT_EQ(rundir::whole_run_error(record).rmse_m, kInfinity)
      << "the whole run must not skip the broken step";
  EXPECT_NE(rundir::result_table(record).find("NOT VALID"), std::string::npos)
      << rundir::result_table(record);
  const auto summary = rundir::summary_json(record);
  EXPECT_EQ(summary["non_finite_estimates"]["steps"], 1);
  EXPECT_TRUE(summary["whole_run"]["rmse_m"].is_null());
  EXPECT_EQ(summary["final"]["non_finite_agents"], 0) << "the final step itself is clean";
}

TEST(NonFiniteEstimates, TrialsCsvNamesTheTrialsThatBroke) {
  MonteCarloResult result;
  result.trials = 2;
  result.final_rmse_per_trial = {0.1, kInfinity};
  result.final_flagged_per_trial = {0, 0};
  result.non_finite_steps_per_trial = {0, 3};
  const auto directory =
      std::filesystem::temp_directory_path() / ("swarmloc-non-finite-trials-" + std::to_string(::getpid()));
  std::filesystem::remove_all(directory);
  std::filesystem::create_directories(directory);
  write_monte_carlo(directory, result);
  std::ifstream in(directory / "trials.csv");
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(),
            "trial,final_rmse_m,flagged_agents,non_finite_steps,bound_rmse_m,bound_ratio,optimum_rmse_m,"
            "efficiency\n0,0.1,0,0,nan,nan,nan,nan\n1,inf,0,3,nan,nan,nan,nan\n");
  std::filesystem::remove_all(directory);
}

}  // namespace
}  // namespace swarmloc::sim
