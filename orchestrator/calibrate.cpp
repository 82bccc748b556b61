#include "calibrate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "calibrate_murp.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/world/mrclam_calibration.hpp"

namespace swarmloc::orchestrator {
namespace {

/// Fewer inlier samples than this and a figure says nothing: exit 2 rather than publish it.
constexpr std::size_t kMinUsableSamples = 20;
std::size_t inliers(const world::RobustStats& s) { return s.samples - s.outliers; }

/// The affine range model is published when its fit is usable: a positive intercept and slope.
bool affine_range(const world::SightingCalibration& s) {
  return s.range_std_intercept_m > 0.0 && s.range_std_slope > 0.0;
}

void print_sightings(const char* what, const world::SightingCalibration& s) {
  std::printf("  %-22s range   bias %+8.4f m    std %.4f m     n %6zu  outliers %5.1f %%  gaps %zu\n", what,
              s.range_m.bias, s.range_m.std, s.range_m.samples, 100.0 * s.range_m.outlier_fraction(),
              s.skipped_gap);
  std::printf(
      "  %-22s bearing bias %+8.4f rad  std %.4f rad   (tails kept: range %.3f m, bearing %.3f rad)\n", "",
      s.bearing_rad.bias, s.bearing_rad.std, s.range_m.all_std, s.bearing_rad.all_std);
}

void print_range_bins(const world::SightingCalibration& s) {
  std::printf("  range std by true range (landmarks, inliers):");
  for (const auto& bin : s.range_bins) {
    std::printf(" [%.0f,%.0f) m %.3f (bias %+.3f, n %zu);", bin.from_m, bin.to_m, bin.std_m, bin.bias_m,
                bin.samples);
  }
  std::printf("\n  fitted: range std = %.4f m + %.4f x range\n", s.range_std_intercept_m, s.range_std_slope);
}

void print_same_frame(const world::SightingCalibration& s) {
  std::printf(
      "  sightings of two landmarks in one frame (same robot, <= %.2f s apart, both inliers, less the "
      "robot's\n"
      "  mean), by how far apart the landmarks are:\n"
      "      separation (m)   pairs   range rho   bearing rho\n",
      world::kSameFrameS);
  for (const auto& bin : s.same_frame) {
    std::printf("      [%4.2f, %6.2f)   %6zu    %+6.3f      %+6.3f%s\n", bin.from_m,
                std::min(bin.to_m, 999.0), bin.pairs, bin.range_rho, bin.bearing_rho,
                bin.pairs < world::kMinBinSamples ? "   (too few)" : "");
  }
  std::printf("  landmarks closer than %.2f m share one error stream (range rho >= %.1f)\n",
              s.cluster_radius_m, world::kClusterMinRho);
}

void print_correlation(const world::SightingCorrelation& c) {
  std::printf(
      "  correlation of consecutive sightings (same landmark, same robot, both inliers, gap <= %.0f s,\n"
      "  residuals less their robot's mean; Pearson per gap bin; (fit) = the model below at the mean gap):\n"
      "      gap (s)        pairs  mean gap   range rho (fit)   bearing rho (fit)\n",
      world::kMaxCorrelationGapS);
  for (const auto& bin : c.bins) {
    const double decay = c.correlation_time_s > 0.0 ? std::exp(-bin.mean_gap_s / c.correlation_time_s) : 0.0;
    std::printf("      [%5.2f, %6.2f)  %6zu  %7.2f s   %+6.3f (%+6.3f)   %+6.3f (%+6.3f)%s\n", bin.from_s,
                bin.to_s, bin.pairs, bin.mean_gap_s, bin.range_rho, c.range_fraction * decay, bin.bearing_rho,
                c.bearing_fraction * decay,
                bin.pairs < world::kMinBinSamples ? "  (too few, not fitted)" : "");
  }
  std::printf(
      "  fitted rho(gap) = c exp(-gap/tau), pair-weighted least squares over the bins, one tau for both:\n"
      "      tau %.2f s   c_range %.3f   c_bearing %.3f   (alone: range tau %.2f s, bearing tau %.2f s)\n",
      c.correlation_time_s, c.range_fraction, c.bearing_fraction, c.range_only_time_s, c.bearing_only_time_s);
}

void print_odometry(const world::RobotCalibration& calibration) {
  for (const auto& w : calibration.odometry) {
    std::printf(
        "  odometry %.1f s windows   v_std %.4f m/sqrt(s)  omega_std %.4f rad/sqrt(s)  distance bias %+.4f m "
        " "
        "turn bias %+.4f rad  distance ratio %.4f  n %zu  outliers %.1f %%  gaps %zu\n"
        "      heavy tails kept (only > 5 std dropped): v_std %.4f  omega_std %.4f\n",
        w.window_s, w.v_std(), w.omega_std(), w.distance_m.bias, w.heading_rad.bias, w.distance_ratio,
        w.distance_m.samples, 100.0 * w.distance_m.outlier_fraction(), w.skipped_gap, w.v_std_with_tails(),
        w.omega_std_with_tails());
  }
  const auto& h = calibration.horizon;
  std::printf(
      "  odometry over the sightings' horizon (%.1f s windows, n %zu, gaps %zu; published): mean included,\n"
      "      v_rms %.4f m/sqrt(s)  omega_rms %.4f rad/sqrt(s)  (distance mean %+.4f m, turn mean %+.4f "
      "rad)\n",
      h.window_s, h.distance_m.samples, h.skipped_gap, h.v_rms_with_tails(), h.omega_rms_with_tails(),
      h.distance_m.all_mean, h.heading_rad.all_mean);
}

void print_lag(const world::OdometryLag& lag) {
  std::printf(
      "Odometry command lag (the robots follow their commands late; every odometry figure below uses it):\n"
      "  heading std over %.1f s windows, pooled, by the lag the commands are shifted by:\n   ",
      world::kLagWindowS);
  for (std::size_t k = 0; k < lag.curve.size(); k += 5) {
    std::printf(" %.2f s: %.4f rad", lag.curve[k][0], lag.curve[k][1]);
  }
  std::printf("\n  least at %.2f s\n\n", lag.lag_s);
}

void print_report(const std::string& dir, const world::MrclamCalibration& c) {
  std::printf("Noise of %s measured against its groundtruth\n", dir.c_str());
  std::printf(
      "  sightings: measured - true range/bearing, groundtruth interpolated at the sighting's timestamp\n"
      "  (skipped when the groundtruth rows around it are > %.2f s apart); outliers: outside the pose\n"
      "  filters' gate, chi-square %.1f of (range, bearing) in stds (iterated from median/MAD), std "
      "corrected\n"
      "  for the trimmed tails.\n"
      "  odometry: unicycle arcs of the odometry rows against the groundtruth pose change over tiled "
      "windows\n"
      "  (skipped across groundtruth gaps); distance along the odometry chord, heading change; "
      "std/sqrt(window).\n\n",
      c.options.max_groundtruth_gap_s, c.options.sighting_gate_chi2);
  const auto& b = c.range_bias;
  std::printf(
      "Range bias across the image (pooled inlier landmark sightings, n %zu; removed from every figure "
      "below):\n"
      "  b(bearing) = %+.4f m %+.4f m/rad * bearing %+.4f m/rad^2 * bearing^2   (range std %.4f m -> %.4f "
      "m)\n\n",
      b.samples, b.constant_m, b.per_rad, b.per_rad2, b.std_before_m, b.std_after_m);
  print_lag(c.odometry_lag);
  for (std::size_t r = 0; r < c.robots.size(); ++r) {
    std::printf("Robot %zu\n", r + 1);
    print_sightings("landmark sightings", c.robots[r].landmarks);
    print_sightings("robot sightings", c.robots[r].robots);
    print_odometry(c.robots[r]);
  }
  std::printf("\nPooled (all robots; the published figures)\n");
  print_sightings("landmark sightings", c.pooled.landmarks);
  print_sightings("robot sightings", c.pooled.robots);
  print_range_bins(c.pooled.landmarks);
  print_correlation(c.pooled.landmarks.correlation);
  print_same_frame(c.pooled.landmarks);
  print_odometry(c.pooled);
}

void require_usable(const world::MrclamCalibration& c) {
  if (inliers(c.pooled.landmarks.range_m) < kMinUsableSamples) {
    throw config::ScenarioError("calibrate: fewer than " + std::to_string(kMinUsableSamples) +
                                " landmark sightings with groundtruth around them");
  }
  if (inliers(c.pooled.horizon.distance_m) < kMinUsableSamples) {
    throw config::ScenarioError("calibrate: fewer than " + std::to_string(kMinUsableSamples) +
                                " odometry windows with groundtruth at both ends");
  }
}

}  // namespace

/// The keys of the pooled model. Range: the affine std fitted over range bins (the constant std when the
/// fit is unusable); bearing: the std of the landmark sightings inside the filters' gate (the robot
/// sightings are reported, not published: the filters give both kinds one model). Odometry: the RMS with
/// heavy tails and mean over windows of the sightings' correlation time (commanded velocities against real
/// motion, a speed scale error: error the filter must carry until sightings bring new information).
/// Sighting correlation: the white + Gauss–Markov fit of the landmark sightings.
std::string noise_fragment(const std::string& dir, const world::MrclamCalibration& c) {
  const auto& odometry = c.pooled.horizon;
  const auto& landmarks = c.pooled.landmarks;
  const auto& correlation = landmarks.correlation;
  std::ostringstream text;
  text.precision(4);
  text
      << "# swarmloc calibrate --mrclam " << dir << "\n"
      << "# Pooled over " << c.robots.size() << " robots: " << c.pooled.landmarks.range_m.samples
      << " landmark sightings (" << 100.0 * c.pooled.landmarks.range_m.outlier_fraction() << " % outliers), "
      << odometry.distance_m.samples << " odometry windows of " << odometry.window_s
      << " s (docs/real-data.md, \"Noise model\").\n"
      << "# Biases left in (no key applies them; the odometry densities include the windows' mean): landmark "
      << "range after the bias across the image " << c.pooled.landmarks.range_m.bias << " m, bearing "
      << c.pooled.landmarks.bearing_rad.bias << " rad, odometry distance ratio " << odometry.distance_ratio
      << ".\n"
      << "# Sighting errors: white + first-order Gauss-Markov, fitted to " << correlation.pairs
      << " pairs of consecutive sightings of one landmark by one robot.\n"
      << "noise:\n"
      << "  range_bias_m: " << c.range_bias.constant_m << "\n"
      << "  range_bias_per_rad: " << c.range_bias.per_rad << "\n"
      << "  range_bias_per_rad2: " << c.range_bias.per_rad2 << "\n"
      << "  robot_range_bias_m: " << c.pooled.robots.range_m.bias << "\n";
  if (affine_range(landmarks)) {
    text << "  range_model: affine\n"
         << "  range_std_m: " << landmarks.range_std_intercept_m << "\n"
         << "  range_factor: " << landmarks.range_std_slope << "\n";
  } else {
    text << "  range_std_m: " << landmarks.range_m.std << "\n";
  }
  text << "  bearing_std_rad: " << c.pooled.landmarks.bearing_rad.std << "\n"
       << "  odometry_v_std: " << odometry.v_rms_with_tails() << "\n"
       << "  odometry_omega_std: " << odometry.omega_rms_with_tails() << "\n"
       << "  odometry_lag_s: " << c.odometry_lag.lag_s << "\n"
       << "  sighting_correlation_time_s: " << correlation.correlation_time_s << "\n"
       << "  range_correlated_fraction: " << correlation.range_fraction << "\n"
       << "  bearing_correlated_fraction: " << correlation.bearing_fraction << "\n"
       << "  sighting_cluster_radius_m: " << landmarks.cluster_radius_m << "\n";
  return text.str();
}

world::MrclamCalibration measure_mrclam_noise(const std::string& dir) {
  auto calibration = world::calibrate_mrclam(world::load_mrclam(dir));
  require_usable(calibration);
  return calibration;
}

int run_calibrate(const CalibrateOptions& options) {
  if (!options.murp_dirs.empty()) return run_calibrate_murp(options.murp_dirs, options.out_path);
  try {
    if (options.mrclam_dir.empty()) {
      throw config::ScenarioError("calibrate: --mrclam DIR or --murp DIR [DIR ...] is required");
    }
    const auto calibration = measure_mrclam_noise(options.mrclam_dir);
    print_report(options.mrclam_dir, calibration);
    const auto fragment = noise_fragment(options.mrclam_dir, calibration);
    std::printf(
        "\nScenario keys (replay --mrclam DIR measures them itself; --noise FILE replays with a saved "
        "set):\n%s",
        fragment.c_str());
    if (!options.out_path.empty()) {
      std::ofstream out(options.out_path);
      out << fragment;
      out.flush();
      if (!out) throw config::ScenarioError("--out: cannot write '" + options.out_path + "'");
      std::printf("written to %s\n", options.out_path.c_str());
    }
    return 0;
  } catch (const std::exception& error) {
    // A dataset that cannot be read or scored is bad input, like replay --mrclam's.
    std::fprintf(stderr, "error: %s\n", error.what());
    return 2;
  }
}

}  // namespace swarmloc::orchestrator
