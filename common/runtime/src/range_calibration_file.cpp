#include "swarmloc/runtime/range_calibration_file.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <span>
#include <sstream>
#include <vector>

#include "swarmloc/config/scenario.hpp"

namespace swarmloc::runtime {

// The text of scenarios/murp-range-bias.json (generated at configure time: common/CMakeLists.txt).
extern const char* const kBuiltinMurpCalibration;

namespace {

namespace uwb = estimators::uwb;
using config::ScenarioError;
using nlohmann::json;

/// The keys of the document: the schema's, then the fit's diagnostics that `calibrate --murp` adds
/// (rundir/murp_calibration_file.hpp), read for their types and otherwise ignored.
constexpr std::array<std::string_view, 9> kDocumentKeys{
    "model",       "fitted_on",        "vehicles",   "coefficients_m", "range_std_m", "spread_noise_gain",
    "ranges_used", "outlier_fraction", "spread_bins"};
constexpr std::array<std::string_view, 2> kVehicleKeys{"lever_arms_m", "antenna_offsets_m"};
constexpr std::array<std::string_view, 5> kSpreadBinKeys{"from_m", "to_m", "ranges", "median_spread_m",
                                                         "robust_std_m"};

/// Refuses a key the format does not have: a misspelt one would otherwise be ignored silently.
void only_known_keys(const json& object, std::span<const std::string_view> keys, const std::string& where) {
  for (const auto& item : object.items()) {
    if (std::find(keys.begin(), keys.end(), item.key()) == keys.end())
      throw ScenarioError(where + ": unknown field '" + item.key() + "'");
  }
}

double finite_number(const json& value, const std::string& where) {
  if (!value.is_number()) throw ScenarioError(where + ": expected a number");
  const double number = value.get<double>();
  if (!std::isfinite(number)) throw ScenarioError(where + ": not a finite number");
  return number;
}

const json& field(const json& object, const char* name, const std::string& where) {
  if (!object.is_object() || !object.contains(name))
    throw ScenarioError(where + ": missing field '" + name + "'");
  return object.at(name);
}

VecX numbers(const json& array, const std::string& where) {
  if (!array.is_array()) throw ScenarioError(where + ": expected an array of numbers");
  VecX values(static_cast<Eigen::Index>(array.size()));
  for (std::size_t k = 0; k < array.size(); ++k) {
    values(static_cast<Eigen::Index>(k)) = finite_number(array[k], where + "[" + std::to_string(k) + "]");
  }
  return values;
}

std::size_t non_negative_count(const json& value, const std::string& where) {
  if (!value.is_number_unsigned()) throw ScenarioError(where + ": expected a non-negative integer");
  return value.get<std::size_t>();
}

uwb::VehicleAntennas vehicle(const json& object, const std::string& where) {
  if (!object.is_object())
    throw ScenarioError(where + ": expected {\"lever_arms_m\": [...], \"antenna_offsets_m\": [...]}");
  only_known_keys(object, kVehicleKeys, where);
  uwb::VehicleAntennas antennas;
  const json& arms = field(object, "lever_arms_m", where);
  if (!arms.is_array() || arms.empty())
    throw ScenarioError(where + ".lever_arms_m: expected [[x, y, z], ...]");
  for (std::size_t k = 0; k < arms.size(); ++k) {
    const VecX arm = numbers(arms[k], where + ".lever_arms_m[" + std::to_string(k) + "]");
    if (arm.size() != 3)
      throw ScenarioError(where + ".lever_arms_m[" + std::to_string(k) + "]: expected [x, y, z]");
    antennas.lever_arms_m.emplace_back(arm);
  }
  antennas.offsets_m = numbers(field(object, "antenna_offsets_m", where), where + ".antenna_offsets_m");
  if (antennas.offsets_m.size() != static_cast<Eigen::Index>(antennas.lever_arms_m.size())) {
    throw ScenarioError(where + ".antenna_offsets_m: one offset per lever arm expected");
  }
  return antennas;
}

AgentId vehicle_id(const std::string& key, const std::string& where) {
  std::size_t used = 0;
  int id = 0;
  try {
    id = std::stoi(key, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != key.size() || key.empty())
    throw ScenarioError(where + ": vehicle key '" + key + "' is not a number");
  return id;
}

std::vector<std::string> trial_names(const json& document, const std::string& source) {
  std::vector<std::string> names;
  if (!document.contains("fitted_on")) return names;
  const json& trials = document.at("fitted_on");
  if (!trials.is_array()) throw ScenarioError(source + ".fitted_on: expected an array of trial names");
  for (std::size_t k = 0; k < trials.size(); ++k) {
    if (!trials[k].is_string())
      throw ScenarioError(source + ".fitted_on[" + std::to_string(k) + "]: expected a trial name (a string)");
    names.push_back(trials[k].get<std::string>());
  }
  return names;
}

void check_spread_bin(const json& bin, const std::string& where) {
  if (!bin.is_object()) throw ScenarioError(where + ": expected {\"from_m\": ..., \"to_m\": ..., ...}");
  only_known_keys(bin, kSpreadBinKeys, where);
  for (const char* name : {"from_m", "median_spread_m", "robust_std_m"}) {
    if (bin.contains(name)) (void)finite_number(bin.at(name), where + "." + name);
  }
  if (bin.contains("to_m") && !bin.at("to_m").is_null())  // null: the open last bin
    (void)finite_number(bin.at("to_m"), where + ".to_m");
  if (bin.contains("ranges")) (void)non_negative_count(bin.at("ranges"), where + ".ranges");
}

/// The fit's description and diagnostics, which the runtimes do not use: each present one must have its
/// type (model a string, ranges_used a count, outlier_fraction in [0, 1], spread_bins bins).
void check_diagnostics(const json& document, const std::string& source) {
  if (document.contains("model") && !document.at("model").is_string())
    throw ScenarioError(source + ".model: expected a string");
  if (document.contains("ranges_used"))
    (void)non_negative_count(document.at("ranges_used"), source + ".ranges_used");
  if (document.contains("outlier_fraction")) {
    const double fraction = finite_number(document.at("outlier_fraction"), source + ".outlier_fraction");
    if (fraction < 0.0 || fraction > 1.0)
      throw ScenarioError(source + ".outlier_fraction: must lie in [0, 1]");
  }
  if (document.contains("spread_bins")) {
    const json& bins = document.at("spread_bins");
    if (!bins.is_array()) throw ScenarioError(source + ".spread_bins: expected an array of bins");
    for (std::size_t k = 0; k < bins.size(); ++k)
      check_spread_bin(bins[k], source + ".spread_bins[" + std::to_string(k) + "]");
  }
}

}  // namespace

uwb::RangeCalibration parse_range_calibration(std::string_view text, const std::string& source) {
  const json document = json::parse(text, nullptr, false);
  if (document.is_discarded() || !document.is_object()) throw ScenarioError(source + ": not a JSON object");
  only_known_keys(document, kDocumentKeys, source);
  uwb::RangeCalibration calibration;
  const json& vehicles = field(document, "vehicles", source);
  if (!vehicles.is_object() || vehicles.empty())
    throw ScenarioError(source + ".vehicles: expected {\"1\": {...}, ...}");
  for (const auto& [key, value] : vehicles.items()) {
    std::string where = source;
    where += ".vehicles.";
    where += key;
    calibration.vehicles[vehicle_id(key, where)] = vehicle(value, where);
  }
  const VecX coefficients = numbers(field(document, "coefficients_m", source), source + ".coefficients_m");
  if (coefficients.size() != uwb::RangeBias::kFeatures) {
    throw ScenarioError(source + ".coefficients_m: expected " + std::to_string(uwb::RangeBias::kFeatures) +
                        " numbers");
  }
  calibration.coefficients_m = coefficients;
  calibration.range_std_m = finite_number(field(document, "range_std_m", source), source + ".range_std_m");
  if (!(calibration.range_std_m > 0.0)) throw ScenarioError(source + ".range_std_m: must be positive");
  calibration.spread_noise_gain =
      finite_number(field(document, "spread_noise_gain", source), source + ".spread_noise_gain");
  if (calibration.spread_noise_gain < 0.0)
    throw ScenarioError(source + ".spread_noise_gain: must not be negative");
  calibration.fitted_on = trial_names(document, source);
  check_diagnostics(document, source);
  return calibration;
}

uwb::RangeCalibration read_range_calibration(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw ScenarioError("range calibration '" + path.string() + "': cannot be read");
  std::ostringstream text;
  text << in.rdbuf();
  return parse_range_calibration(text.str(), "range calibration '" + path.string() + "'");
}

std::string range_calibration_json(const uwb::RangeCalibration& calibration, const std::string& model) {
  json vehicles = json::object();
  for (const auto& [id, antennas] : calibration.vehicles) {
    json arms = json::array();
    for (const auto& arm : antennas.lever_arms_m) arms.push_back({arm.x(), arm.y(), arm.z()});
    json offsets = json::array();
    for (Eigen::Index k = 0; k < antennas.offsets_m.size(); ++k) offsets.push_back(antennas.offsets_m(k));
    vehicles[std::to_string(id)] = {{"lever_arms_m", arms}, {"antenna_offsets_m", offsets}};
  }
  json coefficients = json::array();
  for (Eigen::Index k = 0; k < calibration.coefficients_m.size(); ++k)
    coefficients.push_back(calibration.coefficients_m(k));
  const json document = {{"model", model},
                         {"fitted_on", calibration.fitted_on},
                         {"vehicles", vehicles},
                         {"coefficients_m", coefficients},
                         {"range_std_m", calibration.range_std_m},
                         {"spread_noise_gain", calibration.spread_noise_gain}};
  return document.dump(2) + "\n";
}

uwb::RangeCalibration builtin_murp_calibration() {
  if (std::string_view(kBuiltinMurpCalibration).empty()) {
    throw ScenarioError(
        "this build has no built-in MURP calibration (scenarios/murp-range-bias.json); give --bias FILE");
  }
  return parse_range_calibration(kBuiltinMurpCalibration, "built-in scenarios/murp-range-bias.json");
}

}  // namespace swarmloc::runtime
