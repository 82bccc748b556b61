#include "swarmloc/rundir/murp_calibration_file.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/runtime/output_file.hpp"

namespace swarmloc::rundir {
namespace {

using nlohmann::json;
using nlohmann::ordered_json;  // written in the order a reader wants: what it means first

/// What the figures mean, written into the file for a reader without this code.
constexpr const char* kModelDescription =
    "range - ring-geometric range = vehicles[base].antenna_offsets_m[i] + "
    "vehicles[target].antenna_offsets_m[j] + coefficients_m . (|s|, s^2, s, f_base + f_target, f_base^2 + "
    "f_target^2), s = sine of the line of sight's elevation, f = cosine between an antenna's lever arm and "
    "the line of sight to the other vehicle; std = sqrt(range_std_m^2 + (spread_noise_gain * spread^2)^2), "
    "spread = the std of the readings averaged into the window (I_J_std). Fitted by Huber-weighted ridge "
    "least squares against the motion-capture poses (swarmloc calibrate --murp).";

/// The vehicles' keys in "vehicles", in order.
constexpr std::array<const char*, world::kMurpVehicles> kVehicleKeys{"1", "2", "3"};
/// A lever arm read back must be the ring's to this (the file holds them at full precision).
constexpr double kLeverArmToleranceM = 1e-6;

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

ordered_json vehicles_json(const world::MurpRangeCalibration& c) {
  const auto arms = world::murp_lever_arms();
  ordered_json vehicles = ordered_json::object();
  for (std::size_t v = 0; v < kVehicleKeys.size(); ++v) {
    ordered_json lever_arms = ordered_json::array();
    for (const auto& arm : arms) lever_arms.push_back({arm.x(), arm.y(), arm.z()});
    vehicles[kVehicleKeys[v]] = {{"lever_arms_m", lever_arms}, {"antenna_offsets_m", c.antenna_offsets_m[v]}};
  }
  return vehicles;
}

ordered_json coefficients_json(const world::MurpRangeCalibration& c) {
  ordered_json coefficients = ordered_json::array();
  for (Eigen::Index f = 0; f < c.coefficients_m.size(); ++f) coefficients.push_back(c.coefficients_m(f));
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

/// `value` as an array of `count` finite numbers; errors name `key` in `fields`.
std::vector<double> finite_numbers(const CalibrationFields& fields, const json& value, const std::string& key,
                                   std::size_t count, const std::string& what) {
  if (!value.is_array() || value.size() != count) fields.fail(key, "must be an array of " + what);
  std::vector<double> numbers;
  for (std::size_t k = 0; k < value.size(); ++k) {
    numbers.push_back(fields.finite_number(value[k], key + "[" + std::to_string(k) + "]"));
  }
  return numbers;
}

/// The lever arms must be the ring: MurpRangeCalibration holds none of its own, so others would be lost.
void check_lever_arms(const CalibrationFields& vehicle) {
  const auto ring = world::murp_lever_arms();
  const json& arms = vehicle.at("lever_arms_m");
  if (!arms.is_array() || arms.size() != ring.size()) {
    vehicle.fail("lever_arms_m", "must be an array of " + std::to_string(ring.size()) + " [x, y, z]");
  }
  for (std::size_t k = 0; k < ring.size(); ++k) {
    const std::string key = "lever_arms_m[" + std::to_string(k) + "]";
    const auto arm = finite_numbers(vehicle, arms[k], key, 3, "3 numbers [x, y, z] (m)");
    if ((Vec3(arm[0], arm[1], arm[2]) - ring[k]).norm() > kLeverArmToleranceM) {
      vehicle.fail(key,
                   "is not antenna " + std::to_string(k + 1) + " of the MURP ring (world::murp_lever_arms)");
    }
  }
}

void read_vehicles(const CalibrationFields& fields, const std::string& source,
                   world::MurpRangeCalibration& c) {
  const CalibrationFields vehicles(fields.at("vehicles"), fields.path("vehicles"), source);
  vehicles.only({kVehicleKeys.begin(), kVehicleKeys.end()});
  for (std::size_t v = 0; v < kVehicleKeys.size(); ++v) {
    const CalibrationFields vehicle(vehicles.at(kVehicleKeys[v]), vehicles.path(kVehicleKeys[v]), source);
    vehicle.only({"lever_arms_m", "antenna_offsets_m"});
    check_lever_arms(vehicle);
    const auto offsets = finite_numbers(vehicle, vehicle.at("antenna_offsets_m"), "antenna_offsets_m",
                                        world::kMurpAntennas, "6 numbers (m)");
    std::copy(offsets.begin(), offsets.end(), c.antenna_offsets_m[v].begin());
  }
}

void read_coefficients(const CalibrationFields& fields, world::MurpRangeCalibration& c) {
  const auto coefficients = finite_numbers(fields, fields.at("coefficients_m"), "coefficients_m",
                                           estimators::uwb::RangeBias::kFeatures, "5 numbers (m)");
  for (std::size_t f = 0; f < coefficients.size(); ++f) {
    c.coefficients_m(static_cast<Eigen::Index>(f)) = coefficients[f];
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
  fields.only({"model", "fitted_on", "vehicles", "coefficients_m", "range_std_m", "spread_noise_gain",
               "ranges_used", "outlier_fraction", "spread_bins"});
  if (!fields.at("model").is_string()) fields.fail("model", "must be a string");
  world::MurpRangeCalibration c;
  read_trials(fields, c);
  read_vehicles(fields, source, c);
  read_coefficients(fields, c);
  read_noise(fields, c);
  read_bins(fields, source, c);
  return c;
}

}  // namespace

std::string murp_calibration_json(const world::MurpRangeCalibration& c) {
  const ordered_json document = {{"model", kModelDescription},   {"fitted_on", c.trials},
                                 {"vehicles", vehicles_json(c)}, {"coefficients_m", coefficients_json(c)},
                                 {"range_std_m", c.range_std_m}, {"spread_noise_gain", c.spread_noise_gain},
                                 {"ranges_used", c.ranges_used}, {"outlier_fraction", c.outlier_fraction},
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
