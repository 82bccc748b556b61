#include "swarmloc/rundir/murp_calibration_file.hpp"

#include <array>
#include <cmath>
#include <nlohmann/json.hpp>

#include "swarmloc/runtime/output_file.hpp"

namespace swarmloc::rundir {
namespace {

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

}  // namespace swarmloc::rundir
