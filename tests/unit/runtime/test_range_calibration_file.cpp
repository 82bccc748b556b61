// The UWB range calibration file the team runtimes read (runtime/range_calibration_file.hpp): what
// range_calibration_json writes reads back bit for bit, with or without the fit's diagnostics that
// `calibrate --murp` adds; the built-in MURP calibration parses; and a damaged file, or one with a key the
// format does not have, is refused with its name and the field.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "process_helpers.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/runtime/range_calibration_file.hpp"

namespace swarmloc::runtime {
namespace {

namespace uwb = estimators::uwb;

/// Two vehicles of different antenna counts, figures that do not round in binary.
uwb::RangeCalibration sample_range_calibration() {
  uwb::RangeCalibration calibration;
  for (const AgentId id : {1, 7}) {
    uwb::VehicleAntennas antennas;
    const int count = id == 1 ? 3 : 2;
    antennas.offsets_m.resize(count);
    for (int k = 0; k < count; ++k) {
      antennas.lever_arms_m.emplace_back(0.1 * (k + 1), -0.3 / id, 0.07);
      antennas.offsets_m(k) = -0.1 - 0.013 * k / id;
    }
    calibration.vehicles[id] = antennas;
  }
  calibration.coefficients_m << 1.0582189726683011, -0.5973732438294487, -5.0e-05, 0.0021682721450088354,
      0.047;
  calibration.range_std_m = 0.07862131751823498;
  calibration.spread_noise_gain = 1.282;
  calibration.fitted_on = {"01", "02"};
  return calibration;
}

/// range_calibration_json's document with the diagnostics `calibrate --murp` adds.
nlohmann::json sample_range_calibration_document() {
  nlohmann::json document =
      nlohmann::json::parse(range_calibration_json(sample_range_calibration(), "a test model"));
  document["ranges_used"] = 304560;
  document["outlier_fraction"] = 0.0557;
  document["spread_bins"] = nlohmann::json::array({{{"from_m", 0.0},
                                                    {"to_m", 0.03},
                                                    {"ranges", 40752},
                                                    {"median_spread_m", 0.0228},
                                                    {"robust_std_m", 0.074}},
                                                   {{"from_m", 0.5},
                                                    {"to_m", nullptr},
                                                    {"ranges", 4319},
                                                    {"median_spread_m", 1.009},
                                                    {"robust_std_m", 0.7}}});
  return document;
}

void expect_same_range_calibration(const uwb::RangeCalibration& read, const uwb::RangeCalibration& written) {
  ASSERT_EQ(read.vehicles.size(), written.vehicles.size());
  for (const auto& [id, vehicle] : written.vehicles) {
    ASSERT_EQ(read.vehicles.count(id), 1U) << id;
    EXPECT_EQ(read.vehicles.at(id).lever_arms_m, vehicle.lever_arms_m) << id;
    EXPECT_EQ(read.vehicles.at(id).offsets_m, vehicle.offsets_m) << id;
  }
  EXPECT_EQ(read.coefficients_m, written.coefficients_m);
  EXPECT_EQ(read.range_std_m, written.range_std_m);
  EXPECT_EQ(read.spread_noise_gain, written.spread_noise_gain);
  EXPECT_EQ(read.fitted_on, written.fitted_on);
}

/// parse_range_calibration's ScenarioError message for `document`, or "" (a failure) if it parses.
std::string range_calibration_error(const nlohmann::json& document) {
  try {
    (void)parse_range_calibration(document.dump(), "calibration under test");
  } catch (const config::ScenarioError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("calibration under test"), std::string::npos) << "names the source: " << message;
    return message;
  }
  ADD_FAILURE() << document.dump() << " was accepted";
  return "";
}

bool range_calibration_error_says(const nlohmann::json& document, const std::string& words) {
  const auto message = range_calibration_error(document);
  const bool says = message.find(words) != std::string::npos;
  EXPECT_TRUE(says) << "expected '" << words << "' in: " << message;
  return says;
}

/// Each test's own temporary directory, removed after it.
class RangeCalibrationFile : public ::testing::Test {
 protected:
  const swarmloc::testing::TempDir dir_{"range-calibration"};
};

TEST_F(RangeCalibrationFile, ReadsBackWhatIsWrittenWithOrWithoutTheDiagnostics) {
  const auto written = sample_range_calibration();
  const auto plain = range_calibration_json(written, "a test model");
  expect_same_range_calibration(parse_range_calibration(plain, "plain"), written);
  const auto path = dir_.path() / "with-diagnostics.json";
  std::ofstream(path) << sample_range_calibration_document().dump(2);
  expect_same_range_calibration(read_range_calibration(path), written);
}

TEST_F(RangeCalibrationFile, TheOptionalFieldsMayBeLeftOut) {
  auto document = sample_range_calibration_document();
  for (const char* optional : {"model", "fitted_on", "ranges_used", "outlier_fraction", "spread_bins"})
    document.erase(optional);
  const auto read = parse_range_calibration(document.dump(), "required only");
  EXPECT_TRUE(read.fitted_on.empty());
  EXPECT_EQ(read.range_std_m, sample_range_calibration().range_std_m);
}

TEST_F(RangeCalibrationFile, TheBuiltInCalibrationParsesAsTheShippedFile) {
  const auto builtin = builtin_murp_calibration();
  const auto shipped = read_range_calibration(std::filesystem::path(SWARMLOC_SOURCE_DIR) / "scenarios" /
                                              "murp-range-bias.json");
  expect_same_range_calibration(builtin, shipped);
  ASSERT_EQ(builtin.vehicles.size(), 3U);
  for (const auto& [id, vehicle] : builtin.vehicles) EXPECT_EQ(vehicle.lever_arms_m.size(), 6U) << id;
  EXPECT_EQ(builtin.fitted_on, (std::vector<std::string>{"01", "02", "03", "04", "05", "06", "07", "08", "09",
                                                         "10", "11", "12"}));
}

/// Mutant that fails it: the unknown-key check removed (a misspelt key silently ignored).
TEST_F(RangeCalibrationFile, RefusesAnUnknownKeyNamingItAndTheSource) {
  auto document = sample_range_calibration_document();
  document["spread_noise_gian"] = 2.0;
  EXPECT_TRUE(range_calibration_error_says(document, "unknown field 'spread_noise_gian'"));
  document = sample_range_calibration_document();
  document["vehicles"]["7"]["antenna_offset_m"] = nlohmann::json::array({0.0, 0.0});
  EXPECT_TRUE(range_calibration_error_says(document, "vehicles.7: unknown field 'antenna_offset_m'"));
  document = sample_range_calibration_document();
  document["spread_bins"][1]["robust_std"] = 0.7;
  EXPECT_TRUE(range_calibration_error_says(document, "spread_bins[1]: unknown field 'robust_std'"));

  const auto path = dir_.path() / "typo.json";
  document = sample_range_calibration_document();
  document["range_sdt_m"] = 0.1;
  std::ofstream(path) << document.dump();
  try {
    (void)read_range_calibration(path);
    ADD_FAILURE() << "a file with an unknown key was read";
  } catch (const config::ScenarioError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find(path.string()), std::string::npos) << message;
    EXPECT_NE(message.find("unknown field 'range_sdt_m'"), std::string::npos) << message;
  }
}

TEST_F(RangeCalibrationFile, RefusesAMissingRequiredField) {
  for (const char* required : {"vehicles", "coefficients_m", "range_std_m", "spread_noise_gain"}) {
    auto document = sample_range_calibration_document();
    document.erase(required);
    EXPECT_TRUE(range_calibration_error_says(document, std::string("missing field '") + required + "'"));
  }
  for (const char* required : {"lever_arms_m", "antenna_offsets_m"}) {
    auto document = sample_range_calibration_document();
    document["vehicles"]["1"].erase(required);
    EXPECT_TRUE(
        range_calibration_error_says(document, std::string("vehicles.1: missing field '") + required + "'"));
  }
}

TEST_F(RangeCalibrationFile, RefusesANotANumberAndAWrongType) {
  auto document = sample_range_calibration_document();
  document["range_std_m"] = std::numeric_limits<double>::quiet_NaN();  // JSON has no NaN: written as null
  EXPECT_TRUE(range_calibration_error_says(document, "range_std_m: expected a number"));
  document = sample_range_calibration_document();
  document["vehicles"]["1"]["antenna_offsets_m"][2] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(range_calibration_error_says(document, "vehicles.1.antenna_offsets_m[2]: expected a number"));
  document = sample_range_calibration_document();
  document["coefficients_m"][3] = "0.1";
  EXPECT_TRUE(range_calibration_error_says(document, "coefficients_m[3]: expected a number"));
  document = sample_range_calibration_document();
  document["vehicles"]["7"] = nlohmann::json::array({1, 2});
  EXPECT_TRUE(range_calibration_error_says(document, "vehicles.7: expected {"));
  document = sample_range_calibration_document();
  document["fitted_on"] = nlohmann::json::array({"01", 2});
  EXPECT_TRUE(range_calibration_error_says(document, "fitted_on[1]: expected a trial name"));
  document["fitted_on"] = "01";
  EXPECT_TRUE(range_calibration_error_says(document, "fitted_on: expected an array of trial names"));
  document = sample_range_calibration_document();
  document["model"] = 5;
  EXPECT_TRUE(range_calibration_error_says(document, "model: expected a string"));
}

TEST_F(RangeCalibrationFile, RefusesMistypedDiagnostics) {
  auto document = sample_range_calibration_document();
  document["ranges_used"] = -3;
  EXPECT_TRUE(range_calibration_error_says(document, "ranges_used: expected a non-negative integer"));
  document = sample_range_calibration_document();
  document["outlier_fraction"] = 1.5;
  EXPECT_TRUE(range_calibration_error_says(document, "outlier_fraction: must lie in [0, 1]"));
  document["outlier_fraction"] = "0.05";
  EXPECT_TRUE(range_calibration_error_says(document, "outlier_fraction: expected a number"));
  document = sample_range_calibration_document();
  document["spread_bins"] = nlohmann::json::object();
  EXPECT_TRUE(range_calibration_error_says(document, "spread_bins: expected an array of bins"));
  document = sample_range_calibration_document();
  document["spread_bins"][0]["to_m"] = "open";
  EXPECT_TRUE(range_calibration_error_says(document, "spread_bins[0].to_m: expected a number"));
  document = sample_range_calibration_document();
  document["spread_bins"][1]["ranges"] = 43.5;
  EXPECT_TRUE(
      range_calibration_error_says(document, "spread_bins[1].ranges: expected a non-negative integer"));
  document = sample_range_calibration_document();
  document["spread_bins"][0]["median_spread_m"] = nullptr;
  EXPECT_TRUE(range_calibration_error_says(document, "spread_bins[0].median_spread_m: expected a number"));
}

TEST_F(RangeCalibrationFile, RefusesAWrongNumberOfOffsetsCoordinatesOrCoefficients) {
  auto document = sample_range_calibration_document();
  document["vehicles"]["1"]["antenna_offsets_m"].erase(2);
  EXPECT_TRUE(
      range_calibration_error_says(document, "vehicles.1.antenna_offsets_m: one offset per lever arm"));
  document = sample_range_calibration_document();
  document["vehicles"]["7"]["lever_arms_m"][1] = nlohmann::json::array({0.3, 0.0});
  EXPECT_TRUE(range_calibration_error_says(document, "vehicles.7.lever_arms_m[1]: expected [x, y, z]"));
  document = sample_range_calibration_document();
  document["coefficients_m"].erase(4);
  EXPECT_TRUE(range_calibration_error_says(document, "coefficients_m: expected 5 numbers"));
  document = sample_range_calibration_document();
  document["vehicles"] = nlohmann::json::object();
  EXPECT_TRUE(range_calibration_error_says(document, "vehicles: expected {"));
  document = sample_range_calibration_document();
  document["vehicles"]["one"] = document["vehicles"]["1"];
  EXPECT_TRUE(range_calibration_error_says(document, "vehicle key 'one' is not a number"));
}

TEST_F(RangeCalibrationFile, RefusesANoiseOutsideItsRange) {
  auto document = sample_range_calibration_document();
  document["range_std_m"] = -0.08;
  EXPECT_TRUE(range_calibration_error_says(document, "range_std_m: must be positive"));
  document["range_std_m"] = 0.0;
  EXPECT_TRUE(range_calibration_error_says(document, "range_std_m: must be positive"));
  document = sample_range_calibration_document();
  document["spread_noise_gain"] = -1.0;
  EXPECT_TRUE(range_calibration_error_says(document, "spread_noise_gain: must not be negative"));
}

TEST_F(RangeCalibrationFile, RefusesTextThatIsNotAnObjectAndAMissingFile) {
  for (const char* text : {"range_std_m: 0.08\n", "[1, 2]", "{ not json"}) {
    try {
      (void)parse_range_calibration(text, "text under test");
      ADD_FAILURE() << text << " was accepted";
    } catch (const config::ScenarioError& error) {
      EXPECT_STREQ(error.what(), "text under test: not a JSON object");
    }
  }
  const auto absent = dir_.path() / "absent.json";
  try {
    (void)read_range_calibration(absent);
    ADD_FAILURE() << "a missing file was read";
  } catch (const config::ScenarioError& error) {
    EXPECT_EQ(std::string(error.what()), "range calibration '" + absent.string() + "': cannot be read");
  }
}

}  // namespace
}  // namespace swarmloc::runtime
