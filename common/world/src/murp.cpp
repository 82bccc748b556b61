#include "swarmloc/world/murp.hpp"

#include <zlib.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <numbers>
#include <optional>
#include <set>
#include <stdexcept>
#include <string_view>
#include <unordered_map>
#include <utility>

#include "swarmloc/config/scenario.hpp"

namespace swarmloc::world {
namespace {

namespace fs = std::filesystem;
using config::ScenarioError;

constexpr std::array<std::pair<int, int>, 6> kMurpPairs{{{1, 2}, {1, 3}, {2, 1}, {2, 3}, {3, 1}, {3, 2}}};
constexpr std::array<std::string_view, 6> kPoseFields{"x", "y", "z", "roll", "pitch", "yaw"};
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
using ColumnMatrix = Eigen::Matrix<int, kMurpAntennas, kMurpAntennas>;

/// Where each quantity is in a row, found by name in the header; -1 for a column the file lacks.
struct Columns {
  std::size_t count = 0;
  int time = 0;
  std::array<int, 6> base{};
  std::array<int, 6> target{};
  ColumnMatrix range;
  ColumnMatrix range_std;
  ColumnMatrix truth;
};

/// Names a file and a line in errors.
std::string file_line(const fs::path& file, int line) {
  return "MURP trial: '" + file.string() + "' line " + std::to_string(line);
}

/// The whole text of a plain or gzip-compressed file (zlib reads both).
std::string read_text(const fs::path& path) {
  gzFile file = gzopen(path.c_str(), "rb");
  if (file == nullptr) throw ScenarioError("MURP trial: cannot open '" + path.string() + "'");
  std::string text;
  std::array<char, 1 << 16> buffer{};
  int got = 0;
  while ((got = gzread(file, buffer.data(), static_cast<unsigned>(buffer.size()))) > 0) {
    text.append(buffer.data(), static_cast<std::size_t>(got));
  }
  gzclose(file);
  if (got < 0) throw ScenarioError("MURP trial: '" + path.string() + "' is not readable gzip or text");
  return text;
}

bool all_digits(std::string_view text) {
  return !text.empty() && std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; });
}

/// NN of a file named NN_base-A_targ-B_win-1_step-1.csv[.gz] (digits for NN, A and B); nullopt otherwise.
std::optional<std::string> trial_of_file(std::string_view name) {
  if (name.ends_with(".gz")) name.remove_suffix(3);
  constexpr std::string_view kTail = "_win-1_step-1.csv";
  if (!name.ends_with(kTail)) return std::nullopt;
  name.remove_suffix(kTail.size());
  const auto base = name.find("_base-");
  const auto target = name.find("_targ-");
  if (base == std::string_view::npos || target == std::string_view::npos || target < base)
    return std::nullopt;
  const auto trial = name.substr(0, base);
  if (!all_digits(trial) || !all_digits(name.substr(base + 6, target - base - 6)) ||
      !all_digits(name.substr(target + 6))) {
    return std::nullopt;
  }
  return std::string(trial);
}

/// The one trial number of the directory's MURP files: pairs of two trials must not be mixed up.
std::string trial_number(const fs::path& directory) {
  if (!fs::is_directory(directory)) {
    throw ScenarioError("MURP trial: '" + directory.string() + "' is not a directory");
  }
  std::set<std::string> trials;
  for (const auto& entry : fs::directory_iterator(directory)) {
    if (const auto trial = trial_of_file(entry.path().filename().string())) trials.insert(*trial);
  }
  if (trials.empty()) {
    throw ScenarioError("MURP trial: '" + directory.string() +
                        "' holds no MURP file NN_base-A_targ-B_win-1_step-1.csv[.gz]");
  }
  if (trials.size() > 1) {
    std::string list;
    for (const auto& trial : trials) list += (list.empty() ? "" : ", ") + trial;
    throw ScenarioError("MURP trial: '" + directory.string() + "' holds files of trials " + list +
                        ": one trial per directory");
  }
  return *trials.begin();
}

fs::path pair_file(const fs::path& directory, const std::string& trial, int base, int target) {
  const std::string stem =
      trial + "_base-" + std::to_string(base) + "_targ-" + std::to_string(target) + "_win-1_step-1.csv";
  for (const auto* suffix : {"", ".gz"}) {
    if (fs::exists(directory / (stem + suffix))) return directory / (stem + suffix);
  }
  throw ScenarioError("MURP trial: '" + directory.string() + "' misses the pair base " +
                      std::to_string(base) + ", target " + std::to_string(target) + " of trial " + trial +
                      " (" + stem + "[.gz])");
}

std::vector<std::string_view> split_fields(std::string_view line) {
  std::vector<std::string_view> fields;
  for (std::size_t start = 0;;) {
    const auto comma = line.find(',', start);
    fields.push_back(line.substr(start, comma - start));
    if (comma == std::string_view::npos) return fields;
    start = comma + 1;
  }
}

Columns find_columns(std::string_view header, const fs::path& file, int line) {
  std::unordered_map<std::string_view, int> index;
  const auto names = split_fields(header);
  for (std::size_t k = 0; k < names.size(); ++k) index.emplace(names[k], static_cast<int>(k));
  const auto at = [&](const std::string& name, bool required) {
    const auto found = index.find(name);
    if (found != index.end()) return found->second;
    if (required) throw ScenarioError(file_line(file, line) + ": the header has no column '" + name + "'");
    return -1;
  };
  Columns columns;
  columns.count = names.size();
  columns.time = at("t", true);
  for (std::size_t k = 0; k < kPoseFields.size(); ++k) {
    columns.base[k] = at("A_" + std::string(kPoseFields[k]), true);
    columns.target[k] = at("B_" + std::string(kPoseFields[k]), true);
  }
  for (int i = 0; i < kMurpAntennas; ++i) {
    for (int j = 0; j < kMurpAntennas; ++j) {
      const std::string pair = std::to_string(i + 1) + "_" + std::to_string(j + 1);
      columns.range(i, j) = at(pair, true);
      columns.range_std(i, j) = at(pair + "_std", true);
      columns.truth(i, j) = at(pair + "_t", false);
    }
  }
  return columns;
}

/// A field's number; an empty field is a missing value (NaN), anything but a number an error.
double parse_number(std::string_view field, const fs::path& file, int line) {
  if (field.empty()) return kNan;
  double value = 0.0;
  const auto [end, error] = std::from_chars(field.data(), field.data() + field.size(), value);
  if (error != std::errc() || end != field.data() + field.size()) {
    throw ScenarioError(file_line(file, line) + ": '" + std::string(field.substr(0, 40)) +
                        "' is not a number");
  }
  return value;
}

std::vector<double> parse_row(std::string_view line, const Columns& columns, const fs::path& file,
                              int line_number) {
  const auto fields = split_fields(line);
  if (fields.size() != columns.count) {
    throw ScenarioError(file_line(file, line_number) + ": " + std::to_string(fields.size()) +
                        " fields where the header has " + std::to_string(columns.count) +
                        " (a truncated row?)");
  }
  std::vector<double> row;
  row.reserve(fields.size());
  for (const auto field : fields) row.push_back(parse_number(field, file, line_number));
  return row;
}

/// The pose of the six columns `at` (x, y, z in metres, roll, pitch, yaw in degrees); nullopt if any is
/// not finite.
std::optional<MurpPose> murp_pose(const std::vector<double>& row, const std::array<int, 6>& at) {
  std::array<double, 6> v{};
  for (std::size_t k = 0; k < v.size(); ++k) {
    v[k] = row[static_cast<std::size_t>(at[k])];
    if (!std::isfinite(v[k])) return std::nullopt;
  }
  constexpr double kRadPerDeg = std::numbers::pi / 180.0;
  return MurpPose{Vec3(v[0], v[1], v[2]), v[3] * kRadPerDeg, v[4] * kRadPerDeg, v[5] * kRadPerDeg};
}

double value_at(const std::vector<double>& row, int column) {
  return column < 0 ? kNan : row[static_cast<std::size_t>(column)];
}

/// The row's window, or nullopt if it has no time, no pose for either vehicle or too few ranges.
std::optional<MurpWindow> window_of(const std::vector<double>& row, const Columns& columns) {
  MurpWindow window;
  window.time_s = value_at(row, columns.time);
  const auto base = murp_pose(row, columns.base);
  const auto target = murp_pose(row, columns.target);
  if (!std::isfinite(window.time_s) || !base || !target) return std::nullopt;
  window.base = *base;
  window.target = *target;
  for (int i = 0; i < kMurpAntennas; ++i) {
    for (int j = 0; j < kMurpAntennas; ++j) {
      const double truth = value_at(row, columns.truth(i, j));
      window.truth_ranges_m(i, j) = std::isfinite(truth) ? truth : kNan;
      const double range = value_at(row, columns.range(i, j));
      if (!std::isfinite(range) || range <= 0.0) continue;  // no reading: stays NaN, and so does its std
      window.ranges_m(i, j) = range;
      const double spread = value_at(row, columns.range_std(i, j));
      window.range_std_m(i, j) = std::isfinite(spread) ? spread : kNan;
    }
  }
  if (window.valid_ranges() < kMurpMinValidRanges) return std::nullopt;
  return window;
}

MurpPairLog load_pair(const fs::path& file, int base, int target) {
  MurpPairLog log{base, target, file, {}, 0};
  const std::string text = read_text(file);
  std::optional<Columns> columns;
  int line_number = 0;
  for (std::size_t start = 0; start < text.size();) {
    const auto newline = std::min(text.find('\n', start), text.size());
    std::string_view line(text.data() + start, newline - start);
    start = newline + 1;
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.empty()) continue;
    if (!columns) {
      columns = find_columns(line, file, line_number);
      continue;
    }
    if (auto window = window_of(parse_row(line, *columns, file, line_number), *columns)) {
      log.windows.push_back(std::move(*window));
    } else {
      ++log.skipped_windows;
    }
  }
  if (!columns) throw ScenarioError("MURP trial: '" + file.string() + "' is empty");
  return log;
}

}  // namespace

int MurpWindow::valid_ranges() const { return static_cast<int>(ranges_m.array().isFinite().count()); }

const MurpPairLog& MurpTrial::pair(int base, int target) const {
  for (const auto& log : pairs) {
    if (log.base == base && log.target == target) return log;
  }
  throw std::out_of_range("MURP trial " + name + " has no pair base " + std::to_string(base) + ", target " +
                          std::to_string(target));
}

MurpTrial load_murp_trial(const std::filesystem::path& directory) {
  MurpTrial trial;
  trial.name = trial_number(directory);
  trial.directory = directory;
  for (const auto& [base, target] : kMurpPairs) {
    trial.pairs.push_back(load_pair(pair_file(directory, trial.name, base, target), base, target));
  }
  return trial;
}

Mat3 murp_rotation(const MurpPose& pose) {
  return (Eigen::AngleAxisd(pose.roll_rad, Vec3::UnitX()) * Eigen::AngleAxisd(pose.pitch_rad, Vec3::UnitY()) *
          Eigen::AngleAxisd(pose.yaw_rad, Vec3::UnitZ()))
      .toRotationMatrix();
}

}  // namespace swarmloc::world
