#include "swarmloc/rundir/murp_calibration_file.hpp"

#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/runtime/output_file.hpp"

namespace swarmloc::rundir {
namespace {

using nlohmann::json;
using nlohmann::ordered_json;  // written in the order a reader wants: what it means first

/// What the figures mean, written into the file for a reader without this code.
constexpr const char* kModelDescription =
    "range - ring-geometric range = antenna_offsets_m[base vehicle][i] + antenna_offsets_m[target "
    "vehicle][j] + abs_sin_elevation * |s| + sin_elevation_sq * s^2 + sin_elevation * s + facing_sum * "
    "(f_base + f_target) + facing_sq_sum * (f_base^2 + f_target^2) (coefficients_m), s = sine of the line "
    "of sight's elevation, f = cosine between an antenna's lever arm and the line of sight to the other "
    "vehicle; std = sqrt(range_std_m^2 + (spread_noise_gain * spread^2)^2), spread = the std of the "
    "readings averaged into the window (I_J_std). Antennas on a ring of radius 0.32 m at 30 + 60 * (I - 1) "
    "degrees in the body x-y plane; arrays hold vehicles 1-3 and antennas 1-6 in order.";

/// The feature names of RangeBias::Features, in its order (estimators/uwb/relative_pose.hpp).
constexpr std::array<const char*, estimators::uwb::RangeBias::kFeatures> kFeatureNames{
    "abs_sin_elevation", "sin_elevation_sq", "sin_elevation", "facing_sum", "facing_sq_sum"};

/// A JSON object's fields, each read with its type checked; errors name the file and the field's path.
class CalibrationFields {
 public:
  CalibrationFields(const json& object, std::string where, const std::string& source)
      : object_(object), where_(std::move(where)), source_(source) {
    if (!object_.is_object()) fail("", "must be an object");
  }
  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    throw config::ScenarioError(source_ + ": invalid MURP range calibration: " + path(key) + " " + what);
  }
  [[nodiscard]] std::string path(const std::string& key) const {
    if (key.empty()) return where_.empty() ? "the document" : where_;
    return where_.empty() ? key : where_ + "." + key;
  }
  [[nodiscard]] const json& at(const std::string& key) const {
    const auto it = object_.find(key);
    if (it == object_.end()) fail(key, "is missing");
    return *it;
  }
  [[nodiscard]] double number(const std::string& key) const { return finite_number(at(key), key); }
  [[nodiscard]] double finite_number(const json& value, const std::string& key) const {
    if (!value.is_number()) fail(key, "must be a number");
    const double x = value.get<double>();
    if (!std::isfinite(x)) fail(key, "must be finite");
    return x;
  }
  [[nodiscard]] std::size_t count(const std::string& key) const {
    const json& value = at(key);
    if (!value.is_number_unsigned()) fail(key, "must be a non-negative integer");
    return value.get<std::size_t>();
  }
  /// Rejects a key the format does not have: a misspelt one would otherwise be ignored silently.
  void only(const std::set<std::string>& keys) const {
    for (const auto& item : object_.items()) {
      if (!keys.contains(item.key())) fail(item.key(), "is not a field of the format");
    }
  }

 private:
  const json& object_;
  std::string where_;
  const std::string& source_;
};

ordered_json offsets_json(const world::MurpRangeCalibration& c) {
  ordered_json vehicles = ordered_json::array();
  for (const auto& offsets : c.antenna_offsets_m) vehicles.push_back(offsets);
  return vehicles;
}

ordered_json coefficients_json(const world::MurpRangeCalibration& c) {
  ordered_json coefficients = ordered_json::object();
  for (std::size_t f = 0; f < kFeatureNames.size(); ++f) {
    coefficients[kFeatureNames[f]] = c.coefficients_m(static_cast<Eigen::Index>(f));
  }
  return coefficients;
}

ordered_json bins_json(const world::MurpRangeCalibration& c) {
  ordered_json bins = ordered_json::array();
  for (const auto& bin : c.spread_bins) {
    bins.push_back({{"from_m", bin.from_m},
                    {"to_m", std::isfinite(bin.to_m) ? ordered_json(bin.to_m) : ordered_json()},
                    {"ranges", bin.ranges},
                    {"median_spread_m", bin.median_spread_m},
                    {"robust_std_m", bin.robust_std_m}});
  }
  return bins;
}

void read_offsets(const CalibrationFields& fields, world::MurpRangeCalibration& c) {
  const json& vehicles = fields.at("antenna_offsets_m");
  if (!vehicles.is_array() || vehicles.size() != world::kMurpVehicles) {
    fields.fail("antenna_offsets_m",
                "must be an array of " + std::to_string(world::kMurpVehicles) + " vehicles' offsets");
  }
  for (std::size_t v = 0; v < c.antenna_offsets_m.size(); ++v) {
    const std::string key = "antenna_offsets_m[" + std::to_string(v) + "]";
    const json& offsets = vehicles[v];
    if (!offsets.is_array() || offsets.size() != world::kMurpAntennas) {
      fields.fail(key, "must be an array of " + std::to_string(world::kMurpAntennas) + " numbers (m)");
    }
    for (std::size_t i = 0; i < offsets.size(); ++i) {
      c.antenna_offsets_m[v][i] = fields.finite_number(offsets[i], key + "[" + std::to_string(i) + "]");
    }
  }
}

void read_coefficients(const CalibrationFields& fields, const std::string& source,
                       world::MurpRangeCalibration& c) {
  const CalibrationFields coefficients(fields.at("coefficients_m"), fields.path("coefficients_m"), source);
  coefficients.only({kFeatureNames.begin(), kFeatureNames.end()});
  for (std::size_t f = 0; f < kFeatureNames.size(); ++f) {
    c.coefficients_m(static_cast<Eigen::Index>(f)) = coefficients.number(kFeatureNames[f]);
  }
}

void read_trials(const CalibrationFields& fields, world::MurpRangeCalibration& c) {
  const json& trials = fields.at("fitted_on");
  if (!trials.is_array()) fields.fail("fitted_on", "must be an array of trial names");
  for (const json& trial : trials) {
    if (!trial.is_string()) fields.fail("fitted_on", "must hold trial names (strings)");
    c.trials.push_back(trial.get<std::string>());
  }
}

world::MurpSpreadBin read_bin(const CalibrationFields& bin) {
  bin.only({"from_m", "to_m", "ranges", "median_spread_m", "robust_std_m"});
  world::MurpSpreadBin out;
  out.from_m = bin.number("from_m");
  out.to_m = bin.at("to_m").is_null() ? std::numeric_limits<double>::infinity() : bin.number("to_m");
  if (!(out.from_m >= 0.0 && out.to_m > out.from_m)) bin.fail("", "must have 0 <= from_m < to_m");
  out.ranges = bin.count("ranges");
  out.median_spread_m = bin.number("median_spread_m");
  out.robust_std_m = bin.number("robust_std_m");
  if (out.median_spread_m < 0.0 || out.robust_std_m < 0.0) bin.fail("", "must have non-negative figures");
  return out;
}

void read_bins(const CalibrationFields& fields, const std::string& source, world::MurpRangeCalibration& c) {
  const json& bins = fields.at("spread_bins");
  if (!bins.is_array()) fields.fail("spread_bins", "must be an array of bins");
  for (std::size_t b = 0; b < bins.size(); ++b) {
    c.spread_bins.push_back(
        read_bin(CalibrationFields(bins[b], "spread_bins[" + std::to_string(b) + "]", source)));
  }
}

void read_noise(const CalibrationFields& fields, world::MurpRangeCalibration& c) {
  c.range_std_m = fields.number("range_std_m");
  if (!(c.range_std_m > 0.0)) fields.fail("range_std_m", "must be > 0");
  c.spread_noise_gain = fields.number("spread_noise_gain");
  if (c.spread_noise_gain < 0.0) fields.fail("spread_noise_gain", "must be >= 0");
  c.ranges_used = fields.count("ranges_used");
  c.outlier_fraction = fields.number("outlier_fraction");
  if (c.outlier_fraction < 0.0 || c.outlier_fraction > 1.0)
    fields.fail("outlier_fraction", "must lie in [0, 1]");
}

world::MurpRangeCalibration read_document(const CalibrationFields& fields, const std::string& source) {
  fields.only({"model", "fitted_on", "antenna_offsets_m", "coefficients_m", "range_std_m",
               "spread_noise_gain", "ranges_used", "outlier_fraction", "spread_bins"});
  if (!fields.at("model").is_string()) fields.fail("model", "must be a string");
  world::MurpRangeCalibration c;
  read_trials(fields, c);
  read_offsets(fields, c);
  read_coefficients(fields, source, c);
  read_noise(fields, c);
  read_bins(fields, source, c);
  return c;
}

}  // namespace

std::string murp_calibration_json(const world::MurpRangeCalibration& c) {
  const ordered_json document = {
      {"model", kModelDescription},           {"fitted_on", c.trials},
      {"antenna_offsets_m", offsets_json(c)}, {"coefficients_m", coefficients_json(c)},
      {"range_std_m", c.range_std_m},         {"spread_noise_gain", c.spread_noise_gain},
      {"ranges_used", c.ranges_used},         {"outlier_fraction", c.outlier_fraction},
      {"spread_bins", bins_json(c)}};
  return document.dump(2) + "\n";
}

void write_murp_calibration(const world::MurpRangeCalibration& calibration,
                            const std::filesystem::path& path) {
  runtime::write_text_file(path, murp_calibration_json(calibration));
}

world::MurpRangeCalibration parse_murp_calibration(const std::string& text, const std::string& source) {
  json document;
  try {
    document = json::parse(text);
  } catch (const json::exception& error) {
    throw config::ScenarioError(source + ": not a JSON MURP range calibration: " + error.what());
  }
  try {
    return read_document(CalibrationFields(document, "", source), source);
  } catch (const json::exception& error) {  // e.g. a count beyond size_t
    throw config::ScenarioError(source + ": invalid MURP range calibration: " + error.what());
  }
}

world::MurpRangeCalibration read_murp_calibration(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw config::ScenarioError(path.string() + ": cannot read the MURP range calibration");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw config::ScenarioError(path.string() + ": cannot read the MURP range calibration");
  return parse_murp_calibration(text.str(), path.string());
}

}  // namespace swarmloc::rundir
