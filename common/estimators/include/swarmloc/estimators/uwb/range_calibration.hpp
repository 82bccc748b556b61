#pragma once
// What a team's UWB range model needs to know about its vehicles (docs/real-data.md, "MURP"): each vehicle's
// antenna lever arms and per-antenna range offsets, the geometric bias coefficients and the noise model. It
// is fitted offline (`swarmloc calibrate --murp`) and read from a file by the runtimes; here it is plain
// data.
#include <map>
#include <string>
#include <vector>

#include "swarmloc/estimators/uwb/relative_pose.hpp"

namespace swarmloc::estimators::uwb {

struct VehicleAntennas {
  std::vector<Vec3> lever_arms_m;
  VecX offsets_m;  ///< one per antenna (empty: zero)
};

struct RangeCalibration {
  std::map<AgentId, VehicleAntennas> vehicles;
  RangeBias::Features coefficients_m = RangeBias::Features::Zero();
  double range_std_m = 0.08;
  double spread_noise_gain = 0.0;
  /// Where the figures come from (e.g. the calibration trials), for the record.
  std::vector<std::string> fitted_on;
};

/// The range model `base` uses for its ranges to `target`: both vehicles' lever arms, base's offsets as mine,
/// target's as the peer's, the shared coefficients and noise. Throws std::out_of_range when either vehicle is
/// not in the calibration.
RelativePoseParams range_model(const RangeCalibration& calibration, AgentId base, AgentId target);

/// The same calibration with every bias term zero (lever arms and noise kept).
RangeCalibration without_bias(RangeCalibration calibration);

}  // namespace swarmloc::estimators::uwb
