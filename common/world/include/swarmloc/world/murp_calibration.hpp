#pragma once
// The range model of the MURP UWB dataset fitted to its calibration trials' motion-capture truth
// (`swarmloc calibrate --murp`, docs/real-data.md "MURP range calibration"): each range's bias as per-antenna
// offsets plus a function of the line of sight (estimators::uwb::RangeBias), and its noise as a floor that
// grows with the spread of the readings averaged into the window. Transport-free and without I/O: it reads
// loaded MurpTrials; the run directory library writes the file (rundir/murp_calibration_file.hpp) and the
// runtimes read it (runtime/range_calibration_file.hpp).
#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "swarmloc/estimators/uwb/range_calibration.hpp"
#include "swarmloc/estimators/uwb/relative_pose.hpp"
#include "swarmloc/world/murp.hpp"

namespace swarmloc::world {

/// The robust std of the bias-corrected residuals of the ranges whose spread lies in [from_m, to_m).
struct MurpSpreadBin {
  double from_m = 0.0;
  double to_m = 0.0;
  std::size_t ranges = 0;
  double median_spread_m = 0.0;  ///< where the model is evaluated: the spread that matches a median-based std
  double robust_std_m = 0.0;     ///< 1.4826·median |residual|; 0 for an empty bin
};

struct MurpRangeCalibration {
  /// antenna_offsets_m[v][i]: the delay of antenna i (0-based) of vehicle v + 1, added to every range it
  /// takes part in, as base or as target.
  std::array<std::array<double, kMurpAntennas>, kMurpVehicles> antenna_offsets_m{};
  estimators::uwb::RangeBias::Features coefficients_m = estimators::uwb::RangeBias::Features::Zero();
  double range_std_m = 0.0;        ///< σ0: 1.4826·median |residual| after the bias
  double spread_noise_gain = 0.0;  ///< κ of σ(spread) = √(σ0² + (κ·spread²)²), fitted to spread_bins
  std::size_t ranges_used = 0;
  double outlier_fraction = 0.0;    ///< of the ranges, residual beyond kMurpOutlierSigmas·σ0
  std::vector<std::string> trials;  ///< the trials fitted (MurpTrial::name)
  std::vector<MurpSpreadBin> spread_bins;
};

/// Fewer ranges than this and the 23 parameters say little about the data: refuse to fit.
inline constexpr std::size_t kMurpMinCalibrationRanges = 1000;
inline constexpr double kMurpOutlierSigmas = 3.0;
/// The IRLS fit: Huber threshold in robust stds, iterations, ridge on the normal equations (keeps them
/// regular when a trial leaves an antenna or a geometry feature unexercised).
inline constexpr double kMurpHuberThreshold = 1.5;
inline constexpr int kMurpFitIterations = 10;
inline constexpr double kMurpRidge = 1e-3;
/// The spread bins' edges (m); the last bin is open.
inline constexpr std::array<double, 8> kMurpSpreadEdges{0.0, 0.03, 0.05, 0.08, 0.12, 0.2, 0.3, 0.5};

/// Fits the range model to every valid range of every window of every ordered pair of `trials` against the
/// ring geometry at both vehicles' motion-capture poses. Throws config::ScenarioError when the trials hold
/// fewer than kMurpMinCalibrationRanges valid ranges.
MurpRangeCalibration calibrate_murp_ranges(const std::vector<MurpTrial>& trials);

/// The antennas' lever arms: a ring of kMurpAntennas of radius 0.32 m in the body x-y plane, antenna i
/// (0-based) at 30° + 60°·i (the dataset authors' model; docs/real-data.md "MURP range calibration").
std::vector<Vec3> murp_lever_arms();

/// The bias model's features of antenna i of `base` and antenna j of `target` at their true poses (the
/// line of sight in the world frame), and that pair's geometric range.
struct MurpPairGeometry {
  double range_m = 0.0;
  estimators::uwb::RangeBias::Features features;
};
/// Throws std::out_of_range for an antenna outside 0–5.
MurpPairGeometry murp_pair_geometry(const MurpPose& base, const MurpPose& target, int base_antenna,
                                    int target_antenna);

/// The calibration as the team runtimes take it: vehicles 1–3, each with the ring (murp_lever_arms) and its
/// offsets; the coefficients, noise and trials as fitted.
estimators::uwb::RangeCalibration murp_range_calibration(const MurpRangeCalibration& calibration);

/// The relative pose filter's parameters for `base` (me) ranging to `target` (the peer), vehicles 1–3:
/// the ring's lever arms, the calibration's bias and noise (estimators::uwb::range_model of
/// murp_range_calibration), and random walks set for the dataset's vehicles
/// (heading_walk_radps 0.2, position_walk_mps 3.0; set, not fitted: docs/real-data.md "MURP range
/// calibration"). `calibration` nullptr: no bias and the RelativePoseParams defaults for the noise. Throws
/// std::invalid_argument for a vehicle outside 1–3 or base == target.
estimators::uwb::RelativePoseParams murp_range_model(const MurpRangeCalibration* calibration, int base,
                                                     int target);

}  // namespace swarmloc::world
