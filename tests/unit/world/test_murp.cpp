// The MIT MURP UWB loader: on the real trials (skipped with a message when the dataset is absent;
// tests/support/dataset_paths.hpp) and on small hand-made files in temporary directories.
#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "dataset_paths.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/world/murp.hpp"

namespace swarmloc::world {
namespace {

namespace fs = std::filesystem;
constexpr double kDeg = std::numbers::pi / 180.0;

/// The parsed/ directory of the real dataset, or empty (the test then skips).
fs::path murp_dataset() {
  const auto dir = testing::murp_parsed(SWARMLOC_SOURCE_DIR);
  return !dir.empty() && fs::exists(dir) ? dir : fs::path();
}

#define SKIP_WITHOUT_MURP(dir)                                                                            \
  if ((dir).empty()) {                                                                                    \
    GTEST_SKIP() << "MIT MURP dataset not found (looked for shared/data/mit-murp-uwb/parsed beside "      \
                 << SWARMLOC_SOURCE_DIR << " and its parents; set SWARMLOC_MURP_DIR to its parsed/ dir)"; \
  }

/// The message of the ScenarioError that `load` throws, or "" (a failure) if it throws none.
std::string load_error(const fs::path& dir) {
  try {
    (void)load_murp_trial(dir);
  } catch (const config::ScenarioError& error) {
    return error.what();
  }
  ADD_FAILURE() << "load_murp_trial(" << dir << ") did not throw";
  return "";
}

/// The dataset authors' antenna model: a ring of radius 0.32 m in the body x-y plane, antenna I (0-based
/// here) at 30° + 60°·I.
Vec3 ring_antenna(const MurpPose& pose, int antenna) {
  const double angle = (30.0 + 60.0 * antenna) * kDeg;
  return pose.position_m + murp_rotation(pose) * Vec3(0.32 * std::cos(angle), 0.32 * std::sin(angle), 0.0);
}

// --- The real trials ---------------------------------------------------------------------------------

TEST(MurpTrial13, LoadsSixPairsInOrderWithEveryRowAndTheFirstRowsValues) {
  const auto data = murp_dataset();
  SKIP_WITHOUT_MURP(data);
  const auto trial = load_murp_trial(data / "13");
  EXPECT_EQ(trial.name, "13");
  const std::vector<std::pair<int, int>> order{{1, 2}, {1, 3}, {2, 1}, {2, 3}, {3, 1}, {3, 2}};
  ASSERT_EQ(trial.pairs.size(), order.size());
  for (std::size_t k = 0; k < order.size(); ++k) {
    const auto& log = trial.pairs[k];
    EXPECT_EQ(std::make_pair(log.base, log.target), order[k]);
    EXPECT_EQ(log.windows.size(), 177U) << "rows t = 0..176 of " << log.file;  // every file has 177 rows
    EXPECT_EQ(log.skipped_windows, 0);
    EXPECT_EQ(log.windows.back().time_s, 176.0);
  }
  const auto& first = trial.pair(1, 2).windows.front();
  EXPECT_EQ(first.time_s, 0.0);
  EXPECT_DOUBLE_EQ(first.ranges_m(0, 0), 4.311230732844426);
  EXPECT_DOUBLE_EQ(first.ranges_m(0, 1), 4.1063845707820015);  // "1_2": base antenna 1, target antenna 2
  EXPECT_DOUBLE_EQ(first.ranges_m(1, 0), 4.5470769221966085);  // "2_1"
  EXPECT_DOUBLE_EQ(first.range_std_m(0, 0), 0.0628574964982454);
  EXPECT_DOUBLE_EQ(first.truth_ranges_m(0, 0), 4.385056208211638);
  EXPECT_NEAR(first.base.position_m.z(), 1.749, 1e-3);
  EXPECT_DOUBLE_EQ(first.base.position_m.x(), -0.0301524221465262);
  EXPECT_DOUBLE_EQ(first.base.roll_rad, 0.1228729062168032 * kDeg);
  EXPECT_DOUBLE_EQ(first.target.position_m.y(), 0.6552982146679878);
  EXPECT_DOUBLE_EQ(first.target.pitch_rad, 0.135427727208367 * kDeg);
  EXPECT_DOUBLE_EQ(first.target.yaw_rad, 67.64424028006253 * kDeg);
  EXPECT_EQ(first.valid_ranges(), 36);
  EXPECT_EQ(trial.pair(3, 2).base, 3);
  EXPECT_EQ(trial.pair(3, 2).target, 2);
  EXPECT_THROW((void)trial.pair(1, 1), std::out_of_range);
  EXPECT_THROW((void)trial.pair(1, 4), std::out_of_range);
}

/// The authors' ring model with their R = Rx(roll)·Ry(pitch)·Rz(yaw) reproduces their truth ranges (I_J_t)
/// from the window poses to a tenth of a millimetre: this checks the degree conversion, the yaw, which
/// antenna index is the base's (each of them wrong costs decimetres) and the order of the rotations (the
/// other order leaves 1.3 mm RMS here). The measured ranges scatter about the model by decimetres.
TEST(MurpTrial13, RingAntennaModelReproducesTheTruthRangesToATenthOfAMillimetre) {
  const auto data = murp_dataset();
  SKIP_WITHOUT_MURP(data);
  const auto trial = load_murp_trial(data / "13");
  double squared = 0.0;
  int count = 0;
  std::vector<double> measured_errors;
  for (const auto& log : trial.pairs) {
    for (const auto& w : log.windows) {
      for (int i = 0; i < kMurpAntennas; ++i) {
        for (int j = 0; j < kMurpAntennas; ++j) {
          const double model = (ring_antenna(w.base, i) - ring_antenna(w.target, j)).norm();
          squared += std::pow(model - w.truth_ranges_m(i, j), 2);
          ++count;
          if (std::isfinite(w.ranges_m(i, j))) measured_errors.push_back(std::abs(w.ranges_m(i, j) - model));
        }
      }
    }
  }
  ASSERT_EQ(count, 6 * 177 * 36);
  EXPECT_LT(std::sqrt(squared / count), 1e-4);
  std::nth_element(measured_errors.begin(), measured_errors.begin() + measured_errors.size() / 2,
                   measured_errors.end());
  EXPECT_LT(measured_errors[measured_errors.size() / 2], 0.3);
}

/// Every trial 01-17 loads whole: no window skipped, and the few unusable ranges (0.0 or an empty field)
/// are NaN: five in trial 14, one in 16 (an empty field), one in 17.
TEST(MurpTrials, AllSeventeenLoadWithTheirFewUnusableRangesAsNan) {
  const auto data = murp_dataset();
  SKIP_WITHOUT_MURP(data);
  const std::map<std::string, int> unusable{{"14", 5}, {"16", 1}, {"17", 1}};
  for (int number = 1; number <= 17; ++number) {
    const std::string name = (number < 10 ? "0" : "") + std::to_string(number);
    const auto trial = load_murp_trial(data / name);
    int missing = 0;
    for (const auto& log : trial.pairs) {
      EXPECT_EQ(log.skipped_windows, 0) << log.file;
      for (const auto& w : log.windows) {
        missing += kMurpAntennas * kMurpAntennas - w.valid_ranges();
        EXPECT_TRUE((w.ranges_m.array().isNaN() || w.ranges_m.array() > 0.0).all()) << log.file;
      }
    }
    EXPECT_EQ(missing, unusable.contains(name) ? unusable.at(name) : 0) << "trial " << name;
  }
}

TEST(MurpRotation, IsRollAfterPitchAfterYawAsTheAuthorsHaveIt) {
  MurpPose pose;
  pose.yaw_rad = std::numbers::pi / 2;
  EXPECT_TRUE(
      murp_rotation(pose).isApprox(Eigen::AngleAxisd(pose.yaw_rad, Vec3::UnitZ()).toRotationMatrix()));
  EXPECT_TRUE((murp_rotation(pose) * Vec3::UnitX()).isApprox(Vec3::UnitY()));
  pose.roll_rad = std::numbers::pi / 2;
  // Rx(90°)·Rz(90°) takes y to -x (yaw first); Rz(90°)·Rx(90°) would take it to z.
  EXPECT_TRUE((murp_rotation(pose) * Vec3::UnitY()).isApprox(-Vec3::UnitX(), 1e-12));
  pose = {};
  pose.pitch_rad = std::numbers::pi / 2;
  EXPECT_TRUE((murp_rotation(pose) * Vec3::UnitX()).isApprox(-Vec3::UnitZ(), 1e-12));
  pose.roll_rad = std::numbers::pi / 2;
  // Rx(90°)·Ry(90°) takes y to z (pitch first); Ry(90°)·Rx(90°) would take it to x.
  EXPECT_TRUE((murp_rotation(pose) * Vec3::UnitY()).isApprox(Vec3::UnitZ(), 1e-12));
}

// --- Hand-made files ---------------------------------------------------------------------------------

/// The real files' 169 columns, in their order.
std::vector<std::string> murp_header() {
  std::vector<std::string> names{"t"};
  for (const std::string prefix : {"", "A_", "B_"}) {
    for (const char* field : {"x", "y", "z", "roll", "pitch", "yaw"}) names.push_back(prefix + field);
  }
  for (const std::string suffix : {"", "_std", "_t", "_err"}) {
    for (int i = 1; i <= kMurpAntennas; ++i) {
      for (int j = 1; j <= kMurpAntennas; ++j)
        names.push_back(std::to_string(i) + "_" + std::to_string(j) + suffix);
    }
  }
  for (const char* name : {"r", "r_t", "r_err", "rho", "az", "el"}) names.push_back(name);
  return names;
}

/// One row: base at (1, 2, 1.75) yawed 90°, target at (4, 6, 0.5) rolled 10°; range I_J = 5 + I/10 + J/100,
/// std 0.05, truth 5; `set` overrides fields by column name.
using Row = std::map<std::string, std::string>;
Row murp_row(double time_s, const Row& set = {}) {
  Row row{{"t", std::to_string(time_s)},
          {"A_x", "1"},
          {"A_y", "2"},
          {"A_z", "1.75"},
          {"A_yaw", "90"},
          {"B_x", "4"},
          {"B_y", "6"},
          {"B_z", "0.5"},
          {"B_roll", "10"}};
  for (int i = 1; i <= kMurpAntennas; ++i) {
    for (int j = 1; j <= kMurpAntennas; ++j) {
      const std::string pair = std::to_string(i) + "_" + std::to_string(j);
      row[pair] = std::to_string(5.0 + i / 10.0 + j / 100.0);
      row[pair + "_std"] = "0.05";
      row[pair + "_t"] = "5";
    }
  }
  for (const auto& [name, value] : set) row[name] = value;
  return row;
}

/// CSV text of `rows` under `header` (fields a row does not set are "0").
std::string murp_csv(const std::vector<Row>& rows, const std::vector<std::string>& header = murp_header()) {
  std::string text;
  for (std::size_t k = 0; k < header.size(); ++k) text += (k ? "," : "") + header[k];
  text += "\n";
  for (const auto& row : rows) {
    for (std::size_t k = 0; k < header.size(); ++k) {
      const auto field = row.find(header[k]);
      text += (k ? "," : "") + (field == row.end() ? std::string("0") : field->second);
    }
    text += "\n";
  }
  return text;
}

/// A temporary trial directory, removed afterwards.
class MurpDir {
 public:
  MurpDir() {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("murp-" + std::to_string(::getpid()) + "-" + test->test_suite_name() + "-" + test->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  ~MurpDir() { fs::remove_all(dir_); }
  MurpDir(const MurpDir&) = delete;
  MurpDir& operator=(const MurpDir&) = delete;
  [[nodiscard]] const fs::path& dir() const { return dir_; }

  static std::string file_name(const std::string& trial, int base, int target) {
    return trial + "_base-" + std::to_string(base) + "_targ-" + std::to_string(target) + "_win-1_step-1.csv";
  }
  /// Writes `text` as the pair's file, plain or gzip-compressed.
  void write(int base, int target, const std::string& text, bool gzip = false,
             const std::string& trial = "07") const {
    const auto path = dir_ / (file_name(trial, base, target) + (gzip ? ".gz" : ""));
    if (!gzip) {
      std::ofstream(path, std::ios::binary) << text;
      return;
    }
    gzFile file = gzopen(path.c_str(), "wb");
    ASSERT_NE(file, nullptr);
    ASSERT_EQ(gzwrite(file, text.data(), static_cast<unsigned>(text.size())), static_cast<int>(text.size()));
    gzclose(file);
  }
  /// All six pairs with `text`, except `pair_text` for the pair (1, 2).
  void write_trial(const std::string& text, const std::string& pair_text, bool gzip = false) const {
    for (const auto& [base, target] :
         std::vector<std::pair<int, int>>{{1, 3}, {2, 1}, {2, 3}, {3, 1}, {3, 2}}) {
      write(base, target, text, gzip);
    }
    write(1, 2, pair_text, gzip);
  }

 private:
  fs::path dir_;
};

TEST(MurpLoader, ReadsFieldsByNameAndConvertsDegrees) {
  MurpDir data;
  auto header = murp_header();
  std::reverse(header.begin(), header.end());  // positions must not matter
  const auto text = murp_csv({murp_row(3.0), murp_row(4.0)}, header);
  data.write_trial(text, text);
  const auto trial = load_murp_trial(data.dir());
  EXPECT_EQ(trial.name, "07");
  const auto& w = trial.pair(1, 2).windows.at(1);
  EXPECT_EQ(w.time_s, 4.0);
  EXPECT_EQ(w.base.position_m, Vec3(1, 2, 1.75));
  EXPECT_DOUBLE_EQ(w.base.yaw_rad, std::numbers::pi / 2);
  EXPECT_EQ(w.target.position_m, Vec3(4, 6, 0.5));
  EXPECT_DOUBLE_EQ(w.target.roll_rad, 10.0 * kDeg);
  EXPECT_EQ(w.target.yaw_rad, 0.0);
  EXPECT_DOUBLE_EQ(w.ranges_m(1, 4), 5.25);  // "2_5"
  EXPECT_DOUBLE_EQ(w.ranges_m(4, 1), 5.52);  // "5_2"
  EXPECT_DOUBLE_EQ(w.range_std_m(1, 4), 0.05);
  EXPECT_DOUBLE_EQ(w.truth_ranges_m(1, 4), 5.0);
}

TEST(MurpLoader, PlainCsvLoadsAsGzipDoes) {
  const auto text = murp_csv({murp_row(0.0), murp_row(1.0, {{"3_4", "7.25"}}), murp_row(2.0)});
  MurpDir data;
  data.write_trial(text, text, /*gzip=*/true);
  const auto gzipped = load_murp_trial(data.dir());
  ASSERT_TRUE(gzipped.pair(2, 3).file.string().ends_with(".csv.gz"));
  for (const auto& entry : fs::directory_iterator(data.dir())) fs::remove(entry.path());
  data.write_trial(text, text, /*gzip=*/false);
  const auto plain = load_murp_trial(data.dir());
  ASSERT_TRUE(plain.pair(2, 3).file.string().ends_with(".csv"));
  for (std::size_t k = 0; k < plain.pairs.size(); ++k) {
    ASSERT_EQ(plain.pairs[k].windows.size(), 3U);
    ASSERT_EQ(gzipped.pairs[k].windows.size(), 3U);
    for (std::size_t w = 0; w < 3; ++w) {
      EXPECT_EQ(plain.pairs[k].windows[w].ranges_m, gzipped.pairs[k].windows[w].ranges_m);
      EXPECT_EQ(plain.pairs[k].windows[w].base.position_m, gzipped.pairs[k].windows[w].base.position_m);
    }
  }
  EXPECT_EQ(plain.pair(3, 1).windows[1].ranges_m(2, 3), 7.25);
}

TEST(MurpLoader, UnusableRangesBecomeNanAndAreNotCounted) {
  MurpDir data;
  const auto text = murp_csv({murp_row(
      0.0, {{"1_1", "0.0"}, {"1_2", "-0.5"}, {"2_3", "nan"}, {"4_4", ""}, {"6_6", "inf"}, {"5_5_std", ""}})});
  data.write_trial(murp_csv({murp_row(0.0)}), text);
  const auto trial = load_murp_trial(data.dir());
  const auto& log = trial.pair(1, 2);
  ASSERT_EQ(log.windows.size(), 1U);
  const auto& w = log.windows[0];
  EXPECT_EQ(w.valid_ranges(), 31);
  for (const auto& [i, j] : std::vector<std::pair<int, int>>{{0, 0}, {0, 1}, {1, 2}, {3, 3}, {5, 5}}) {
    EXPECT_TRUE(std::isnan(w.ranges_m(i, j))) << i << "," << j;
    EXPECT_TRUE(std::isnan(w.range_std_m(i, j))) << i << "," << j;  // no range, no spread
    EXPECT_EQ(w.truth_ranges_m(i, j), 5.0) << i << "," << j;        // the truth does not need a reading
  }
  EXPECT_DOUBLE_EQ(w.ranges_m(4, 4), 5.55);
  EXPECT_TRUE(std::isnan(w.range_std_m(4, 4)));  // an empty std: one reading
  EXPECT_DOUBLE_EQ(w.range_std_m(4, 3), 0.05);
}

TEST(MurpLoader, WindowsWithoutFourRangesOrAPoseAreSkippedAndCounted) {
  Row three;  // ranges 1_1, 1_2, 1_3 only
  Row four;   // and 1_4
  for (int i = 1; i <= kMurpAntennas; ++i) {
    for (int j = 1; j <= kMurpAntennas; ++j) {
      const bool kept = i == 1 && j <= 3;
      three[std::to_string(i) + "_" + std::to_string(j)] = kept ? "5" : "0";
      four[std::to_string(i) + "_" + std::to_string(j)] = kept || (i == 1 && j == 4) ? "5" : "";
    }
  }
  MurpDir data;
  data.write_trial(murp_csv({murp_row(0.0)}),
                   murp_csv({murp_row(0.0, three), murp_row(1.0, four), murp_row(2.0, {{"B_pitch", "nan"}}),
                             murp_row(3.0, {{"A_x", ""}}), murp_row(4.0)}));
  const auto trial = load_murp_trial(data.dir());
  const auto& log = trial.pair(1, 2);
  EXPECT_EQ(log.skipped_windows, 3);
  ASSERT_EQ(log.windows.size(), 2U);
  EXPECT_EQ(log.windows[0].time_s, 1.0);
  EXPECT_EQ(log.windows[0].valid_ranges(), 4);
  EXPECT_EQ(log.windows[1].time_s, 4.0);
  EXPECT_EQ(trial.pair(2, 1).skipped_windows, 0);
}

TEST(MurpLoader, MissingPairFileNamesThePair) {
  MurpDir data;
  const auto text = murp_csv({murp_row(0.0)});
  data.write_trial(text, text, /*gzip=*/true);
  fs::remove(data.dir() / (MurpDir::file_name("07", 2, 3) + ".gz"));
  const auto message = load_error(data.dir());
  EXPECT_NE(message.find("base 2, target 3"), std::string::npos) << message;
  EXPECT_NE(message.find("07_base-2_targ-3_win-1_step-1.csv"), std::string::npos) << message;
}

TEST(MurpLoader, TruncatedOrUnparsableRowNamesFileAndLine) {
  MurpDir data;
  const auto good = murp_csv({murp_row(0.0), murp_row(1.0), murp_row(2.0)});
  data.write_trial(good, good.substr(0, good.size() - 200));  // the last row (line 4) cut mid-row
  auto message = load_error(data.dir());
  EXPECT_NE(message.find("07_base-1_targ-2_win-1_step-1.csv' line 4:"), std::string::npos) << message;
  EXPECT_NE(message.find("truncated"), std::string::npos) << message;

  data.write(1, 2, murp_csv({murp_row(0.0), murp_row(1.0, {{"3_3", "4.3x"}})}));
  message = load_error(data.dir());
  EXPECT_NE(message.find("07_base-1_targ-2_win-1_step-1.csv' line 3: '4.3x' is not a number"),
            std::string::npos)
      << message;
}

TEST(MurpLoader, GarbageGzipOrBinaryFileIsAClearError) {
  MurpDir data;
  const auto good = murp_csv({murp_row(0.0)});
  data.write_trial(good, good);
  // The gzip magic and method, then garbage: zlib fails to inflate it.
  std::string garbage = "\x1f\x8b\x08";
  for (int k = 0; k < 4000; ++k) garbage += static_cast<char>((k * 7919) % 256);
  data.write(1, 2, garbage);
  auto message = load_error(data.dir());
  EXPECT_NE(message.find("is not readable gzip or text"), std::string::npos) << message;
  // Binary bytes without the magic: zlib passes them through, and they hold no header.
  data.write(1, 2, garbage.substr(3));
  message = load_error(data.dir());
  EXPECT_NE(message.find("07_base-1_targ-2_win-1_step-1.csv' line"), std::string::npos) << message;
  EXPECT_NE(message.find("the header has no column 't'"), std::string::npos) << message;
}

TEST(MurpLoader, DirectoryWithoutFilesOrWithTwoTrialsIsAnError) {
  MurpDir data;
  std::ofstream(data.dir() / "README.txt") << "not a trial\n";
  auto message = load_error(data.dir());
  EXPECT_NE(message.find("holds no MURP file"), std::string::npos) << message;
  EXPECT_NE(load_error(data.dir() / "absent").find("is not a directory"), std::string::npos);
  const auto text = murp_csv({murp_row(0.0)});
  data.write_trial(text, text);
  data.write(1, 2, text, false, "08");
  message = load_error(data.dir());
  EXPECT_NE(message.find("trials 07, 08"), std::string::npos) << message;
}

}  // namespace
}  // namespace swarmloc::world
