// The MURP range calibration file that `calibrate --murp` writes (rundir/murp_calibration_file.hpp): the
// runtimes' reader (runtime/range_calibration_file.hpp, its only reader, whose own tests refuse damaged
// files) reads back what is written bit for bit, diagnostics and all, as murp_range_calibration gives it;
// the diagnostics are written as the fit gives them; the shipped scenarios/murp-range-bias.json reads.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "process_helpers.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/rundir/murp_calibration_file.hpp"
#include "swarmloc/runtime/range_calibration_file.hpp"

namespace swarmloc::rundir {
namespace {

using nlohmann::json;

/// Each test's own temporary directory, removed after it.
class MurpCalibrationFile : public ::testing::Test {
 protected:
  const swarmloc::testing::TempDir dir_{"murp-calibration"};
};

world::MurpRangeCalibration sample_calibration() {
  world::MurpRangeCalibration c;
  for (std::size_t v = 0; v < c.antenna_offsets_m.size(); ++v) {
    for (std::size_t i = 0; i < c.antenna_offsets_m[v].size(); ++i) {
      c.antenna_offsets_m[v][i] = -0.1 + 0.01 * static_cast<double>(v) + 0.003 * static_cast<double>(i);
    }
  }
  c.coefficients_m << 1.0582189726683011, -0.5973732438294487, -5.0e-05, 0.0021682721450088354, 0.047;
  c.range_std_m = 0.07862131751823498;
  c.spread_noise_gain = 1.282;
  c.ranges_used = 304560;
  c.outlier_fraction = 0.0557;
  c.trials = {"01", "02"};
  c.spread_bins = {{0.0, 0.03, 40752, 0.0228, 0.074},
                   {0.5, std::numeric_limits<double>::infinity(), 4319, 1.009, 0.7067}};
  return c;
}

TEST_F(MurpCalibrationFile, TheRuntimesReadBackEveryFieldOfTheirSchemaAsWritten) {
  const auto path = dir_.path() / "round-trip.json";
  const auto written = sample_calibration();
  write_murp_calibration(written, path);
  const auto read = runtime::read_range_calibration(path);
  const auto ring = world::murp_lever_arms();
  ASSERT_EQ(read.vehicles.size(), written.antenna_offsets_m.size());
  for (std::size_t v = 0; v < written.antenna_offsets_m.size(); ++v) {
    const auto id = static_cast<AgentId>(v + 1);
    ASSERT_EQ(read.vehicles.count(id), 1U) << id;
    const auto& vehicle = read.vehicles.at(id);
    EXPECT_EQ(vehicle.lever_arms_m, ring) << id;
    ASSERT_EQ(vehicle.offsets_m.size(), static_cast<Eigen::Index>(written.antenna_offsets_m[v].size()));
    for (std::size_t i = 0; i < written.antenna_offsets_m[v].size(); ++i)
      EXPECT_EQ(vehicle.offsets_m(static_cast<Eigen::Index>(i)), written.antenna_offsets_m[v][i])
          << id << " " << i;
  }
  EXPECT_EQ(read.coefficients_m, written.coefficients_m);
  EXPECT_EQ(read.range_std_m, written.range_std_m);
  EXPECT_EQ(read.spread_noise_gain, written.spread_noise_gain);
  EXPECT_EQ(read.fitted_on, written.trials);
}

/// The diagnostics the runtimes' schema does not carry, as the file holds them.
TEST_F(MurpCalibrationFile, WritesTheDiagnosticsAndTheOpenBinAsNull) {
  const auto written = sample_calibration();
  const auto text = murp_calibration_json(written);
  EXPECT_EQ(text.find("\"model\""), 4U) << "the description first:\n" << text;
  const auto document = json::parse(text);
  EXPECT_EQ(document.at("ranges_used").get<std::size_t>(), written.ranges_used);
  EXPECT_EQ(document.at("outlier_fraction").get<double>(), written.outlier_fraction);
  EXPECT_EQ(document.at("fitted_on").get<std::vector<std::string>>(), written.trials);
  const json& bins = document.at("spread_bins");
  ASSERT_EQ(bins.size(), 2U);
  EXPECT_TRUE(bins[1].at("to_m").is_null()) << "the open bin: " << bins[1].dump();
  EXPECT_EQ(bins[0].at("to_m").get<double>(), 0.03);
  EXPECT_EQ(bins[1].at("ranges").get<std::size_t>(), 4319U);
  EXPECT_EQ(bins[0].at("median_spread_m").get<double>(), 0.0228);
  EXPECT_EQ(bins[1].at("robust_std_m").get<double>(), 0.7067);
}

TEST_F(MurpCalibrationFile, TheShippedCalibrationReadsAndIsFittedOnTheCalibrationTrials) {
  const auto path = std::filesystem::path(SWARMLOC_SOURCE_DIR) / "scenarios" / "murp-range-bias.json";
  const auto shipped = runtime::read_range_calibration(path);
  EXPECT_EQ(shipped.fitted_on, (std::vector<std::string>{"01", "02", "03", "04", "05", "06", "07", "08", "09",
                                                         "10", "11", "12"}));
  const auto ring = world::murp_lever_arms();
  ASSERT_EQ(shipped.vehicles.size(), 3U);
  for (const auto& [id, vehicle] : shipped.vehicles) {
    ASSERT_EQ(vehicle.lever_arms_m.size(), ring.size()) << id;
    for (std::size_t k = 0; k < ring.size(); ++k)
      EXPECT_LT((vehicle.lever_arms_m[k] - ring[k]).norm(), 1e-6) << "vehicle " << id << " antenna " << k + 1;
  }
  std::ifstream in(path);
  EXPECT_GT(json::parse(in).at("ranges_used").get<std::size_t>(), 100000U);
}

/// A misspelt key in a written file is refused, not ignored (the rest: the runtimes' RangeCalibrationFile.*).
TEST_F(MurpCalibrationFile, TheRuntimesRefuseAWrittenFileWithAnUnknownKey) {
  auto document = json::parse(murp_calibration_json(sample_calibration()));
  document["spread_noise_gian"] = 2.0;
  try {
    (void)runtime::parse_range_calibration(document.dump(), "typo.json");
    ADD_FAILURE() << "an unknown key was accepted";
  } catch (const config::ScenarioError& error) {
    EXPECT_STREQ(error.what(), "typo.json: unknown field 'spread_noise_gian'");
  }
}

/// The MURP replay reads the file with the team runtimes' parser: it must give what murp_range_calibration
/// gives from the fit.
TEST_F(MurpCalibrationFile, TheRuntimesReadTheSameCalibration) {
  const auto written = sample_calibration();
  const auto read = runtime::parse_range_calibration(murp_calibration_json(written), "written");
  const auto expected = world::murp_range_calibration(written);
  ASSERT_EQ(read.vehicles.size(), 3U);
  for (const auto& [id, vehicle] : expected.vehicles) {
    ASSERT_EQ(read.vehicles.count(id), 1U) << id;
    EXPECT_EQ(read.vehicles.at(id).offsets_m, vehicle.offsets_m) << id;
    ASSERT_EQ(read.vehicles.at(id).lever_arms_m.size(), 6U);
    for (std::size_t k = 0; k < 6; ++k)
      EXPECT_EQ(read.vehicles.at(id).lever_arms_m[k], vehicle.lever_arms_m[k]);
  }
  EXPECT_EQ(read.coefficients_m, expected.coefficients_m);
  EXPECT_EQ(read.range_std_m, expected.range_std_m);
  EXPECT_EQ(read.spread_noise_gain, expected.spread_noise_gain);
  EXPECT_EQ(read.fitted_on, expected.fitted_on);
}

}  // namespace
}  // namespace swarmloc::rundir
