#include "swarmloc/estimators/uwb/range_calibration.hpp"

namespace swarmloc::estimators::uwb {

RelativePoseParams range_model(const RangeCalibration& calibration, AgentId base, AgentId target) {
  const auto& mine = calibration.vehicles.at(base);
  const auto& peer = calibration.vehicles.at(target);
  RelativePoseParams params;
  params.my_lever_arms_m = mine.lever_arms_m;
  params.peer_lever_arms_m = peer.lever_arms_m;
  params.bias.my_antenna_offsets_m = mine.offsets_m;
  params.bias.peer_antenna_offsets_m = peer.offsets_m;
  params.bias.coefficients_m = calibration.coefficients_m;
  params.range_std_m = calibration.range_std_m;
  params.spread_noise_gain = calibration.spread_noise_gain;
  return params;
}

RangeCalibration without_bias(RangeCalibration calibration) {
  for (auto& [id, vehicle] : calibration.vehicles) vehicle.offsets_m = VecX::Zero(vehicle.offsets_m.size());
  calibration.coefficients_m.setZero();
  return calibration;
}

}  // namespace swarmloc::estimators::uwb
