// `swarmloc replay --murp DIR --sim` end to end on MURP trial 13 (skipped, with a message, when the dataset
// is absent: tests/support/dataset_paths.hpp): the run directory, the summary's relative errors per pair, and
// bad input — a missing pair file, a calibration that is not one, a vehicle the calibration does not know,
// --murp with another source, a DDS domain in the ephemeral port range — rejected with exit 2 and no summary.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "dataset_paths.hpp"
#include "process_helpers.hpp"

namespace murp_replay_test {
namespace {

namespace fs = std::filesystem;
using swarmloc::testing::fresh_directory;
using swarmloc::testing::read_json;
using swarmloc::testing::run_command;

const std::string kBinary = SWARMLOC_BINARY;

fs::path trial(const std::string& name) {
  const auto parsed = swarmloc::testing::murp_parsed(SWARMLOC_SOURCE_DIR);
  return parsed.empty() ? fs::path() : parsed / name;
}

#define SKIP_WITHOUT_MURP_TRIAL(dir)                                                                      \
  if ((dir).empty() || !fs::exists(dir)) {                                                                \
    GTEST_SKIP() << "MIT MURP dataset not found (shared/data/mit-murp-uwb/parsed beside the checkout or " \
                    "its parents; or SWARMLOC_MURP_DIR)";                                                 \
  }

std::size_t lines(const fs::path& path) {
  std::ifstream in(path);
  std::size_t count = 0;
  for (std::string line; std::getline(in, line);) ++count;
  return count;
}

TEST(MurpReplay, SimWritesTheRunDirectoryAndScoresEveryPairAgainstTheWindowPoses) {
  const auto dir = trial("13");
  SKIP_WITHOUT_MURP_TRIAL(dir);
  const auto out = fresh_directory("murp-sim");
  const auto run =
      run_command(kBinary + " replay --murp " + dir.string() + " --sim -q --force --out " + out.string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("pooled"), std::string::npos) << run.output;
  const auto summary = read_json(out / "summary.json");
  EXPECT_EQ(summary["kind"], "murp");
  EXPECT_EQ(summary["mode"], "sim");
  EXPECT_TRUE(summary["cooperation"].get<bool>());
  const auto& relative = summary["relative"];
  EXPECT_EQ(relative["windows"], 6 * 177);
  EXPECT_EQ(relative["missing_estimates"], 0);
  EXPECT_EQ(relative["per_pair"].size(), 6U);
  EXPECT_NE(relative["truth"].get<std::string>().find("window poses"), std::string::npos);
  // Trial 13 with the built-in calibration (fitted on trials 01-12): near the paper's 0.24 m, not metres off.
  EXPECT_LT(relative["position_mae_m"].get<double>(), 0.3);
  EXPECT_LT(relative["heading_mae_deg"].get<double>(), 7.0);
  EXPECT_EQ(lines(out / "relative.csv"), 1 + 6 * 177U);
  for (const char* pair : {"1_sees_2", "1_sees_3", "2_sees_1", "2_sees_3", "3_sees_1", "3_sees_2"}) {
    EXPECT_EQ(lines(out / "trajectories" / (std::string("vehicle_") + pair + ".tum")), 177U) << pair;
    EXPECT_EQ(lines(out / "trajectories" / (std::string("vehicle_") + pair + "_truth.tum")), 177U) << pair;
  }
  EXPECT_TRUE(fs::exists(out / "range_model.json"));
  EXPECT_TRUE(fs::exists(out / "plots" / "error_range.gp"));
}

TEST(MurpReplay, WithoutBiasAndCooperationTheSummarySaysSoAndTheErrorGrows) {
  const auto dir = trial("13");
  SKIP_WITHOUT_MURP_TRIAL(dir);
  const auto full = fresh_directory("murp-full");
  const auto plain = fresh_directory("murp-plain");
  ASSERT_EQ(
      run_command(kBinary + " replay --murp " + dir.string() + " --sim -q --force --out " + full.string())
          .exit_code,
      0);
  const auto run = run_command(kBinary + " replay --murp " + dir.string() +
                               " --sim -q --no-bias --no-cooperation --force --out " + plain.string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const auto summary = read_json(plain / "summary.json");
  EXPECT_EQ(summary["bias"], "none");
  EXPECT_FALSE(summary["cooperation"].get<bool>());
  EXPECT_GT(summary["relative"]["position_mae_m"].get<double>(),
            read_json(full / "summary.json")["relative"]["position_mae_m"].get<double>() + 0.05);
}

/// Runs replay --murp with `arguments` into a fresh directory: exit 2, a message holding `expected`, no
/// summary.
void expect_rejected(const std::string& arguments, const std::string& expected) {
  const auto out = fresh_directory("murp-bad");
  const auto run = run_command(kBinary + " replay " + arguments + " --sim -q --force --out " + out.string());
  EXPECT_EQ(run.exit_code, 2) << arguments << "\n" << run.output;
  EXPECT_NE(run.output.find(expected), std::string::npos) << arguments << "\n" << run.output;
  EXPECT_FALSE(fs::exists(out / "summary.json")) << arguments;
}

TEST(MurpReplay, BadTrialsAndCalibrationsAreRejectedWithExitTwo) {
  const auto dir = trial("13");
  SKIP_WITHOUT_MURP_TRIAL(dir);
  expect_rejected("--murp /nonexistent/murp/13", "/nonexistent/murp/13");

  const auto partial = fresh_directory("murp-partial");
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.path().filename().string().find("base-3_targ-2") == std::string::npos) {
      fs::copy_file(entry.path(), partial / entry.path().filename());
    }
  }
  expect_rejected("--murp " + partial.string(), "misses the pair base 3");

  const auto garbage = fresh_directory("murp-cal") / "bias.json";
  std::ofstream(garbage) << "{ not json";
  expect_rejected("--murp " + dir.string() + " --bias " + garbage.string(), "not a JSON object");

  const auto two_vehicles = fresh_directory("murp-cal2") / "bias.json";
  std::ofstream(two_vehicles)
      << R"({"vehicles": {"1": {"lever_arms_m": [[0.3, 0, 0], [0, 0.3, 0], [-0.3, 0, 0],
      [0, -0.3, 0], [0.2, 0.2, 0], [-0.2, -0.2, 0]], "antenna_offsets_m": [0, 0, 0, 0, 0, 0]}},
      "coefficients_m": [0, 0, 0, 0, 0], "range_std_m": 0.1, "spread_noise_gain": 0})";
  expect_rejected("--murp " + dir.string() + " --bias " + two_vehicles.string(), "no entry");

  const auto negative = fresh_directory("murp-cal3") / "bias.json";
  std::ofstream(negative) << R"({"vehicles": {"1": {"lever_arms_m": [[0.3, 0, 0]], "antenna_offsets_m": [0]}},
      "coefficients_m": [0, 0, 0, 0, 0], "range_std_m": -0.1, "spread_noise_gain": 0})";
  expect_rejected("--murp " + dir.string() + " --bias " + negative.string(), "range_std_m");

  expect_rejected("--murp " + dir.string() + " --mrclam /tmp", "--murp");

  // Over DDS, a domain whose fixed ports lie in the ephemeral range is bad input too (nothing is started).
  const auto out = fresh_directory("murp-domain");
  const auto run = run_command(kBinary + " replay --murp " + dir.string() +
                               " --domain 150 -q --force --out " + out.string());
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_NE(run.output.find("ephemeral port range"), std::string::npos) << run.output;
  EXPECT_FALSE(fs::exists(out / "summary.json"));
}

}  // namespace
}  // namespace murp_replay_test
