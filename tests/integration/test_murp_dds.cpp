// `swarmloc replay --murp` over DDS (three vehicle processes in lockstep, domain 36) against the in-process
// runner, on MURP trial 13: every reported estimate is the same, with and without cooperation; and a vehicle
// that dies mid-run fails the run without leaving a process behind. Skipped, with a message, when the dataset
// is absent (it is never part of the project; tests/support/dataset_paths.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "dataset_paths.hpp"
#include "process_helpers.hpp"

namespace murp_dds_test {
namespace {

namespace fs = std::filesystem;
using swarmloc::testing::count_processes_matching;
using swarmloc::testing::fresh_directory;
using swarmloc::testing::read_json;
using swarmloc::testing::read_text;
using swarmloc::testing::run_command;

const std::string kBinary = SWARMLOC_BINARY;
const std::string kDomain = "36";

fs::path trial13() {
  const auto parsed = swarmloc::testing::murp_parsed(SWARMLOC_SOURCE_DIR);
  return !parsed.empty() && fs::exists(parsed / "13") ? parsed / "13" : fs::path();
}

#define SKIP_WITHOUT_MURP(dir)                                                                            \
  if ((dir).empty()) {                                                                                    \
    GTEST_SKIP() << "MIT MURP dataset not found (looked for shared/data/mit-murp-uwb/parsed beside "      \
                 << SWARMLOC_SOURCE_DIR << " and its parents; set SWARMLOC_MURP_DIR to its parsed/ dir)"; \
  }

std::vector<std::vector<std::string>> csv_rows(const fs::path& path) {
  std::vector<std::vector<std::string>> rows;
  std::istringstream in(read_text(path));
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::istringstream cells(line);
    for (std::string cell; std::getline(cells, cell, ',');) fields.push_back(cell);
    rows.push_back(fields);
  }
  return rows;
}

/// Every row and field of two relative.csv files equal (numbers to 1e-9, NaN to NaN).
void expect_same_estimates(const fs::path& expected, const fs::path& actual) {
  const auto a = csv_rows(expected);
  const auto b = csv_rows(actual);
  ASSERT_GT(a.size(), 100U) << expected;  // trial 13: 177 windows, six ordered pairs
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t row = 0; row < a.size(); ++row) {
    ASSERT_EQ(a[row].size(), b[row].size()) << "row " << row;
    for (std::size_t field = 0; field < a[row].size(); ++field) {
      if (a[row][field] == b[row][field]) continue;
      const double x = std::strtod(a[row][field].c_str(), nullptr);
      const double y = std::strtod(b[row][field].c_str(), nullptr);
      EXPECT_NEAR(x, y, 1e-9) << "row " << row << " field " << field << ": " << a[row][field] << " vs "
                              << b[row][field];
    }
  }
}

/// A range calibration with every term set (antennas on a 0.32 m ring, offsets and coefficients that are not
/// round binary numbers): the agents read it back from the run's range_model.json, the in-process runner
/// uses it as parsed, and the two must agree to the bit.
std::string write_calibration(const fs::path& dir) {
  std::ostringstream text;
  text << std::setprecision(17) << R"({"model": "test", "fitted_on": [], "vehicles": {)";
  for (int vehicle = 1; vehicle <= 3; ++vehicle) {
    text << (vehicle > 1 ? ", " : "") << '"' << vehicle << R"(": {"lever_arms_m": [)";
    for (int antenna = 0; antenna < 6; ++antenna) {
      const double angle = (30.0 + 60.0 * antenna) * std::numbers::pi / 180.0;
      text << (antenna > 0 ? ", " : "") << '[' << 0.32 * std::cos(angle) << ", " << 0.32 * std::sin(angle)
           << ", 0.1]";
    }
    text << R"(], "antenna_offsets_m": [)";
    for (int antenna = 0; antenna < 6; ++antenna)
      text << (antenna > 0 ? ", " : "") << -0.1 - 0.01 * antenna / vehicle;
    text << "]}";
  }
  text << R"(}, "coefficients_m": [1.0582189726683011, -0.5973732438294487, -5.0e-05, 0.0021682721, 0.03],)"
       << R"( "range_std_m": 0.07862131751823498, "spread_noise_gain": 1.2823305826560218})";
  const auto path = dir / "calibration.json";
  std::ofstream(path) << text.str();
  return " --bias " + path.string();
}

/// The in-process replay and the DDS replay of trial 13 with `flags`; both must succeed and agree.
void expect_dds_equals_sim(const std::string& name, std::string flags) {
  const auto trial = trial13();
  SKIP_WITHOUT_MURP(trial);
  const auto sim = fresh_directory(name + "-sim");
  const auto dds = fresh_directory(name + "-dds");
  flags += write_calibration(fresh_directory(name + "-calibration"));
  const auto in_process = run_command(kBinary + " replay --murp " + trial.string() + flags +
                                      " --sim -q --force --out " + sim.string());
  ASSERT_EQ(in_process.exit_code, 0) << in_process.output;
  const auto over_dds = run_command(kBinary + " replay --murp " + trial.string() + flags + " --domain " +
                                    kDomain + " -q --force --out " + dds.string());
  ASSERT_EQ(over_dds.exit_code, 0) << over_dds.output;
  expect_same_estimates(sim / "relative.csv", dds / "relative.csv");
  const auto expected = read_json(sim / "summary.json");
  const auto actual = read_json(dds / "summary.json");
  EXPECT_EQ(actual["mode"], "dds-lockstep");
  EXPECT_EQ(actual["relative"]["position_mae_m"], expected["relative"]["position_mae_m"]);
  const auto& counters = actual["extra"]["dds"];
  EXPECT_EQ(counters["windows_completed"], 177);
  EXPECT_EQ(counters["samples_rejected"], 0);
  EXPECT_EQ(counters["window_timeouts"], 0);
  EXPECT_EQ(count_processes_matching(dds.string()), 0);
}

TEST(MurpDds, ThreeVehicleProcessesReportWhatTheInProcessRunnerDoes) {
  expect_dds_equals_sim("murp-coop", "");
}

TEST(MurpDds, WithoutCooperationTheyReportWhatTheInProcessRunnerDoes) {
  expect_dds_equals_sim("murp-solo", " --no-cooperation");
}

TEST(MurpDds, AVehicleThatDiesMidRunFailsTheRunAndLeavesNoProcess) {
  const auto trial = trial13();
  SKIP_WITHOUT_MURP(trial);
  const auto out = fresh_directory("murp-kill");
  // Vehicle 2 dies by SIGKILL once it has reported window 40 (agent/uwb_team_agent.cpp: a test aid).
  const auto result = run_command("SWARMLOC_UWB_FAULT=2:40 " + kBinary + " replay --murp " + trial.string() +
                                  write_calibration(fresh_directory("murp-kill-calibration")) + " --domain " +
                                  kDomain + " -q --force --out " + out.string());
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("vehicle 2's agent exited with code 137"), std::string::npos) << result.output;
  EXPECT_EQ(count_processes_matching(out.string()), 0);
  const auto summary = read_json(out / "summary.json");
  EXPECT_NE(summary["extra"]["failure"].get<std::string>().find("vehicle 2"), std::string::npos);
  const auto& counters = summary["extra"]["dds"];
  EXPECT_GE(counters["windows_completed"].get<int>(), 40);  // 0-39 done, and 40 unless the death came first
  EXPECT_LE(counters["windows_completed"].get<int>(), 41);
  EXPECT_EQ(counters["agent_exit_codes"]["2"], 137);
  EXPECT_EQ(counters["agent_exit_codes"]["1"], 0);  // the others were stopped
}

}  // namespace
}  // namespace murp_dds_test
