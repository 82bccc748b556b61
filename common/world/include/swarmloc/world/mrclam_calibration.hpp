#pragma once
// The noise model of a UTIAS MRCLAM dataset measured from its own groundtruth (`swarmloc calibrate`,
// docs/real-data.md "Noise model"): range and bearing residuals of the sightings against the
// groundtruth at the sighting's timestamp, and odometry-integrated motion against the groundtruth motion
// over short windows. Transport-free and without I/O: it reads a loaded MrclamDataset.
#include <array>
#include <cstddef>
#include <optional>
#include <vector>

#include "swarmloc/world/mrclam.hpp"

namespace swarmloc::world {

/// Bias (mean) and std of one residual channel after trimming outliers.
struct RobustStats {
  std::size_t samples = 0;   ///< residuals scored (gaps and unknown subjects already skipped)
  std::size_t outliers = 0;  ///< of those, trimmed as outliers
  double bias = 0.0;         ///< mean of the inliers
  double std = 0.0;          ///< std of the inliers, corrected for the trimmed Gaussian tails
  /// Std of every sample within 5 plain stds of the mean (one pass): gross errors such as groundtruth
  /// glitches dropped, heavy tails kept. Odometry publishes this one: its tails are real motion error.
  double all_std = 0.0;
  double all_mean = 0.0;  ///< mean of the same samples
  [[nodiscard]] double outlier_fraction() const {
    return samples == 0 ? 0.0 : static_cast<double>(outliers) / static_cast<double>(samples);
  }
};

/// Which samples of a residual pair (range and bearing of a sighting; distance and heading of an odometry
/// window) are inliers, from their residuals in stds from each channel's centre. `per_channel`: each
/// channel within `threshold` stds (a box). `joint`: the pair's chi-square (2 degrees of freedom) within
/// `threshold` (an ellipse): the pose filters' innovation gate, so that the sighting figures describe the
/// sightings such a filter accepts (docs/real-data.md, "How each figure is measured").
struct PairTrim {
  enum class Shape { per_channel, joint };
  Shape shape = Shape::per_channel;
  double threshold = 3.0;

  static PairTrim per_channel(double sigma) { return {Shape::per_channel, sigma}; }
  static PairTrim joint(double chi2) { return {Shape::joint, chi2}; }
  /// z0, z1: the pair's residuals in stds from their centres.
  [[nodiscard]] bool inside(double z0, double z1) const;
  /// A residual in stds from its centre; in a channel without spread only the centre itself is inside.
  [[nodiscard]] static double standardized(double deviation, double std);
  /// The variance of one channel of a unit bivariate Gaussian kept by this trim: the inliers' std
  /// underestimates σ by its square root.
  [[nodiscard]] double variance_factor() const;
};

/// Two residual channels of the same samples, trimmed together by `trim`. Starts from the median and
/// 1.4826·MAD, then iterates mean / std of the inliers until the inlier set is stable.
std::array<RobustStats, 2> robust_pair_stats(const std::vector<std::array<double, 2>>& residuals,
                                             PairTrim trim = {});

/// Range residual statistics of the inliers whose true range lies in [from_m, to_m).
struct RangeBin {
  double from_m = 0.0;
  double to_m = 0.0;
  std::size_t samples = 0;
  double bias_m = 0.0;
  double std_m = 0.0;
};

/// Correlation of the residuals of consecutive sightings of one subject by one robot, over the pairs
/// whose gap lies in [from_s, to_s).
struct CorrelationBin {
  double from_s = 0.0;
  double to_s = 0.0;
  std::size_t pairs = 0;
  double mean_gap_s = 0.0;  ///< where the fit evaluates the model for this bin
  double range_rho = 0.0;
  double bearing_rho = 0.0;
};

/// Sighting errors as white noise plus a first-order Gauss–Markov process (docs/real-data.md,
/// "Correlated sighting errors"): two sightings Δt apart correlate by c·exp(−Δt/τ), one τ for both
/// channels, each with its own correlated fraction c of the variance.
struct SightingCorrelation {
  std::vector<CorrelationBin> bins;  ///< every gap bin, also those too thin to fit
  std::size_t pairs = 0;             ///< consecutive inlier pairs at most kMaxCorrelationGapS apart
  double correlation_time_s = 0.0;   ///< τ; 0 when nothing correlates (or no bin could be fitted)
  double range_fraction = 0.0;       ///< c of the range channel, in [0, kMaxCorrelatedFraction]
  double bearing_fraction = 0.0;
  /// Each channel's own best τ, before the common one (how well one τ fits both).
  double range_only_time_s = 0.0;
  double bearing_only_time_s = 0.0;
};

/// Correlation of the residuals of two subjects sighted by one robot in one camera frame (at most
/// kSameFrameS apart), over the pairs whose subjects lie [from_m, to_m) apart.
struct SeparationBin {
  double from_m = 0.0;
  double to_m = 0.0;
  std::size_t pairs = 0;
  double range_rho = 0.0;
  double bearing_rho = 0.0;
};

struct SightingCalibration {
  RobustStats range_m;               ///< measured − true range
  RobustStats bearing_rad;           ///< measured − true bearing, wrapped to (−π, π]
  std::vector<RangeBin> range_bins;  ///< 1 m bins with at least kMinBinSamples inliers
  /// Weighted least-squares line through the bins: range std ≈ intercept + slope · range.
  double range_std_intercept_m = 0.0;
  double range_std_slope = 0.0;
  std::size_t skipped_gap = 0;            ///< sightings without groundtruth around their timestamp
  SightingCorrelation correlation;        ///< of the inliers, per-robot mean removed
  std::vector<SeparationBin> same_frame;  ///< every separation bin, also those too thin to read
  /// Subjects closer than this share one error stream: the upper edge of the last separation bin, from
  /// the nearest on, whose range residuals correlate by at least kClusterMinRho (bins with fewer than
  /// kMinBinSamples pairs are passed over). 0 when the nearest readable bin does not.
  double cluster_radius_m = 0.0;
};

/// Odometry over windows of one length, tiled along each robot's odometry.
struct OdometryCalibration {
  double window_s = 0.0;
  RobustStats distance_m;   ///< groundtruth − odometry distance along the odometry chord
  RobustStats heading_rad;  ///< groundtruth − odometry heading change
  /// Σ groundtruth distance / Σ odometry distance over the inlier windows that moved (> 1 cm): the scale
  /// bias of the odometry's speed.
  double distance_ratio = 1.0;
  std::size_t skipped_gap = 0;  ///< windows with a groundtruth gap inside
  /// The unicycle model's densities: a window of W seconds adds variance v_std²·W (m/√s, rad/√s).
  [[nodiscard]] double v_std() const;
  [[nodiscard]] double omega_std() const;
  /// The same from RobustStats::all_std (tails kept): the published odometry densities.
  [[nodiscard]] double v_std_with_tails() const;
  [[nodiscard]] double omega_std_with_tails() const;
  /// The root mean square with tails kept, the mean included, over √window: the densities a filter needs
  /// when the window's mean (a speed scale error, a turn bias) is error it must carry too.
  [[nodiscard]] double v_rms_with_tails() const;
  [[nodiscard]] double omega_rms_with_tails() const;
};

struct RobotCalibration {
  SightingCalibration landmarks;              ///< sightings of landmarks (subjects 6–20)
  SightingCalibration robots;                 ///< sightings of other robots, against both robots' groundtruth
  std::vector<OdometryCalibration> odometry;  ///< one per CalibrationOptions::windows_s
  /// Windows as long as the pooled sightings' correlation time (at least min_horizon_s): the interval over
  /// which sightings bring new information, so the odometry error a filter must carry between them. The
  /// published densities (docs/real-data.md, "Odometry over the sightings' horizon").
  OdometryCalibration horizon;
};

struct CalibrationOptions {
  /// A groundtruth pose is interpolated only between rows at most this far apart (no gap), and a sighting
  /// needs a row within this time on both sides.
  double max_groundtruth_gap_s = 0.1;
  std::vector<double> windows_s{0.5, 1.0, 2.0, 4.0, 8.0, 16.0};
  double min_horizon_s = 1.0;  ///< the horizon window when sightings are independent (τ = 0) or τ shorter
  /// A sighting is an inlier when it passes the pose filters' gate at this chi-square (2 dof), the replay's
  /// `algorithm.range_bearing_gate_chi2`: the figures then describe the sightings the filters use.
  double sighting_gate_chi2 = 13.8;
  double odometry_trim_sigma = 3.0;  ///< an odometry window is an outlier beyond this many stds per channel

  [[nodiscard]] PairTrim sighting_trim() const { return PairTrim::joint(sighting_gate_chi2); }
  [[nodiscard]] PairTrim odometry_trim() const { return PairTrim::per_channel(odometry_trim_sigma); }
};

/// A range bias that depends on where the subject is in the camera's image: b(β) = constant_m +
/// per_rad·β + per_rad2·β², β the measured bearing (docs/real-data.md, "Range bias across the image").
/// Fitted by least squares to the pooled inlier landmark sightings; every sighting residual the other
/// figures use has it removed.
struct BearingRangeBias {
  double constant_m = 0.0;
  double per_rad = 0.0;
  double per_rad2 = 0.0;
  std::size_t samples = 0;    ///< inlier landmark sightings fitted
  double std_before_m = 0.0;  ///< their range std with and without the bias
  double std_after_m = 0.0;
  [[nodiscard]] double at(double bearing_rad) const {
    return constant_m + per_rad * bearing_rad + per_rad2 * bearing_rad * bearing_rad;
  }
};

/// How late the robots follow their velocity commands (docs/real-data.md, "Odometry command lag"): the lag
/// that best aligns the commanded turn with the groundtruth's, and the trimmed heading std of
/// kLagWindowS windows at each lag tried.
struct OdometryLag {
  double lag_s = 0.0;
  std::vector<std::array<double, 2>> curve;  ///< (lag s, heading std rad) on the grid
};
inline constexpr double kLagWindowS = 1.0;
inline constexpr double kLagStepS = 0.02;
inline constexpr double kMaxLagS = 0.6;

struct MrclamCalibration {
  BearingRangeBias range_bias;           ///< removed before every sighting figure below
  OdometryLag odometry_lag;              ///< applied to every odometry figure below
  std::vector<RobotCalibration> robots;  ///< robots[i] = subject i + 1
  RobotCalibration pooled;               ///< all robots' residuals together (the published figures)
  CalibrationOptions options;
};

inline constexpr std::size_t kMinBinSamples = 30;
/// Two sightings at most this far apart in time are of one camera frame.
inline constexpr double kSameFrameS = 0.05;
inline constexpr double kClusterMinRho = 0.5;
/// Consecutive sightings further apart than this are not paired: the correlation has died out long before.
inline constexpr double kMaxCorrelationGapS = 100.0;
/// A fraction of 1 would leave no white noise, and a filter would treat repeated sightings as one.
inline constexpr double kMaxCorrelatedFraction = 0.99;

MrclamCalibration calibrate_mrclam(const MrclamDataset& data, const CalibrationOptions& options = {});

/// Groundtruth pose at `time_s`, linearly interpolated between the rows around it; nothing when the rows
/// around it are more than `max_gap_s` apart, or `time_s` is outside the track.
std::optional<MrclamDataset::TimedPose> groundtruth_at(const std::vector<MrclamDataset::TimedPose>& track,
                                                       double time_s, double max_gap_s);

}  // namespace swarmloc::world
