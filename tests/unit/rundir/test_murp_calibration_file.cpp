// The MURP range calibration file (rundir/murp_calibration_file.hpp): what calibrate --murp writes reads
// back bit for bit, the shipped scenarios/murp-range-bias.json reads, and a damaged file is refused with
// its name and the field.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/rundir/murp_calibration_file.hpp"
#include "swarmloc/runtime/output_file.hpp"
#include "swarmloc/runtime/range_calibration_file.hpp"

namespace swarmloc::rundir {
namespace {

using nlohmann::json;

std::filesystem::path murp_file_dir() {
  const auto dir =
      std::filesystem::temp_directory_path() / ("swarmloc-murp-calibration-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

/// Removes the files a test wrote.
class MurpCalibrationFile : public ::testing::Test {
 protected:
  void TearDown() override { std::filesystem::remove_all(murp_file_dir()); }
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

TEST_F(MurpCalibrationFile, ReadsBackEveryFieldAsWritten) {
  const auto path = murp_file_dir() / "round-trip.json";
  const auto written = sample_calibration();
  write_murp_calibration(written, path);
  const auto read = read_murp_calibration(path);
  EXPECT_EQ(read.antenna_offsets_m, written.antenna_offsets_m);
  EXPECT_EQ(read.coefficients_m, written.coefficients_m);
  EXPECT_EQ(read.range_std_m, written.range_std_m);
  EXPECT_EQ(read.spread_noise_gain, written.spread_noise_gain);
  EXPECT_EQ(read.ranges_used, written.ranges_used);
  EXPECT_EQ(read.outlier_fraction, written.outlier_fraction);
  EXPECT_EQ(read.trials, written.trials);
  ASSERT_EQ(read.spread_bins.size(), 2U);
  EXPECT_EQ(read.spread_bins[1].to_m, std::numeric_limits<double>::infinity()) << "written as null";
  EXPECT_EQ(read.spread_bins[1].ranges, 4319U);
  EXPECT_EQ(read.spread_bins[0].median_spread_m, 0.0228);
  const auto text = murp_calibration_json(written);
  EXPECT_EQ(text.find("\"model\""), 4U) << "the description first:\n" << text;
}

TEST_F(MurpCalibrationFile, TheShippedCalibrationReadsAndIsFittedOnTheCalibrationTrials) {
  const auto shipped = read_murp_calibration(std::filesystem::path(SWARMLOC_SOURCE_DIR) / "scenarios" /
                                             "murp-range-bias.json");
  EXPECT_EQ(shipped.trials, (std::vector<std::string>{"01", "02", "03", "04", "05", "06", "07", "08", "09",
                                                      "10", "11", "12"}));
  EXPECT_GT(shipped.ranges_used, 100000U);
}

/// The ScenarioError message of reading `document` from a file, or "" (a failure) if it reads.
std::string murp_file_error(const std::string& name, const std::string& text) {
  const auto path = murp_file_dir() / name;
  runtime::write_text_file(path, text);
  try {
    (void)read_murp_calibration(path);
  } catch (const config::ScenarioError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find(path.string()), std::string::npos) << "names the file: " << message;
    return message;
  }
  ADD_FAILURE() << name << " was accepted";
  return "";
}

json sample_document() { return json::parse(murp_calibration_json(sample_calibration())); }

bool mentions(const std::string& message, const std::string& words) {
  return message.find(words) != std::string::npos;
}

TEST_F(MurpCalibrationFile, RefusesAMissingField) {
  for (const char* field : {"range_std_m", "spread_noise_gain", "vehicles", "coefficients_m", "fitted_on",
                            "spread_bins", "ranges_used", "outlier_fraction", "model"}) {
    auto document = sample_document();
    document.erase(field);
    const auto message = murp_file_error("missing.json", document.dump());
    EXPECT_TRUE(mentions(message, std::string(field) + " is missing")) << message;
  }
  auto document = sample_document();
  document["vehicles"]["2"].erase("antenna_offsets_m");
  EXPECT_TRUE(
      mentions(murp_file_error("missing.json", document.dump()), "vehicles.2.antenna_offsets_m is missing"));
}

TEST_F(MurpCalibrationFile, RefusesANotANumberAndAWrongType) {
  auto document = sample_document();
  document["range_std_m"] = std::numeric_limits<double>::quiet_NaN();  // JSON has no NaN: written as null
  EXPECT_TRUE(mentions(murp_file_error("nan.json", document.dump()), "range_std_m must be a number"));
  document = sample_document();
  document["vehicles"]["3"]["antenna_offsets_m"][4] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(mentions(murp_file_error("nan.json", document.dump()),
                       "vehicles.3.antenna_offsets_m[4] must be a number"));
  document = sample_document();
  document["coefficients_m"][3] = "0.1";
  EXPECT_TRUE(
      mentions(murp_file_error("string.json", document.dump()), "coefficients_m[3] must be a number"));
  document = sample_document();
  document["fitted_on"] = json::array({1, 2});
  EXPECT_TRUE(mentions(murp_file_error("trials.json", document.dump()), "fitted_on must hold trial names"));
  document = sample_document();
  document["ranges_used"] = -3;
  EXPECT_TRUE(
      mentions(murp_file_error("count.json", document.dump()), "ranges_used must be a non-negative integer"));
}

TEST_F(MurpCalibrationFile, RefusesAWrongNumberOfVehiclesAntennasOrCoefficients) {
  auto document = sample_document();
  document["vehicles"]["2"]["antenna_offsets_m"].erase(5);
  EXPECT_TRUE(mentions(murp_file_error("five.json", document.dump()),
                       "vehicles.2.antenna_offsets_m must be an array of 6"));
  document = sample_document();
  document["vehicles"].erase("3");
  EXPECT_TRUE(mentions(murp_file_error("two.json", document.dump()), "vehicles.3 is missing"));
  document = sample_document();
  document["vehicles"]["4"] = document["vehicles"]["1"];
  EXPECT_TRUE(mentions(murp_file_error("four.json", document.dump()), "vehicles.4 is not a field"));
  document = sample_document();
  document["coefficients_m"].erase(4);
  EXPECT_TRUE(
      mentions(murp_file_error("four.json", document.dump()), "coefficients_m must be an array of 5"));
}

TEST_F(MurpCalibrationFile, RefusesLeverArmsOtherThanTheRing) {
  auto document = sample_document();
  document["vehicles"]["1"]["lever_arms_m"][2] = json::array({0.3, 0.0, 0.0});
  EXPECT_TRUE(mentions(murp_file_error("arms.json", document.dump()),
                       "vehicles.1.lever_arms_m[2] is not antenna 3 of the MURP ring"));
  document = sample_document();
  document["vehicles"]["1"]["lever_arms_m"].erase(5);
  EXPECT_TRUE(mentions(murp_file_error("arms.json", document.dump()),
                       "vehicles.1.lever_arms_m must be an array of 6"));
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

TEST_F(MurpCalibrationFile, RefusesANoiseOutsideItsRange) {
  auto document = sample_document();
  document["range_std_m"] = -0.08;
  EXPECT_TRUE(mentions(murp_file_error("negative.json", document.dump()), "range_std_m must be > 0"));
  document["range_std_m"] = 0.0;
  EXPECT_TRUE(mentions(murp_file_error("zero.json", document.dump()), "range_std_m must be > 0"));
  document = sample_document();
  document["spread_noise_gain"] = -1.0;
  EXPECT_TRUE(mentions(murp_file_error("gain.json", document.dump()), "spread_noise_gain must be >= 0"));
  document = sample_document();
  document["outlier_fraction"] = 1.5;
  EXPECT_TRUE(
      mentions(murp_file_error("fraction.json", document.dump()), "outlier_fraction must lie in [0, 1]"));
  document = sample_document();
  document["spread_bins"][0]["robust_std_m"] = -0.1;
  EXPECT_TRUE(
      mentions(murp_file_error("bin.json", document.dump()), "spread_bins[0] must have non-negative"));
}

TEST_F(MurpCalibrationFile, RefusesAnUnknownFieldAndText) {
  auto document = sample_document();
  document["spread_noise_gian"] = 2.0;
  EXPECT_TRUE(mentions(murp_file_error("typo.json", document.dump()), "spread_noise_gian is not a field"));
  EXPECT_TRUE(
      mentions(murp_file_error("text.json", "range_std_m: 0.08\n"), "not a JSON MURP range calibration"));
  EXPECT_TRUE(mentions(murp_file_error("array.json", "[1, 2]"), "the document must be an object"));
  try {
    (void)read_murp_calibration(murp_file_dir() / "absent.json");
    ADD_FAILURE() << "a missing file was read";
  } catch (const config::ScenarioError& error) {
    EXPECT_TRUE(mentions(error.what(), "absent.json: cannot read the MURP range calibration"))
        << error.what();
  }
}

}  // namespace
}  // namespace swarmloc::rundir
