// The MRCLAM noise calibration (docs/real-data.md, "Noise model") on a synthetic five-robot dataset with
// known noise: fixed seed, so every figure below is deterministic and the tolerances are several times
// the estimators' sampling error (about 2 % for the stds here).
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>
#include <random>

#include "swarmloc/models/measurement_models.hpp"
#include "swarmloc/world/mrclam_calibration.hpp"

namespace swarmloc::world {
namespace {

struct SyntheticNoise {
  double range_std_m = 0.1;
  double range_bias_m = 0.05;
  double bearing_std_rad = 0.03;
  double v_std = 0.04;         ///< m/√s
  double omega_std = 0.08;     ///< rad/√s
  double misidentified = 0.0;  ///< fraction of sightings labelled with another landmark
  /// Sighting errors as white + first-order Gauss–Markov: this fraction of each channel's variance is a
  /// process per (robot, subject) with correlation time correlation_time_s, the rest white. 0 s: all white.
  double correlation_time_s = 0.0;
  double range_correlated_fraction = 0.0;
  double bearing_correlated_fraction = 0.0;
  double robot_range_bias_step_m = 0.0;  ///< robot r (0-based) adds (r − 2) × this to range_bias_m
  double speed_scale = 1.0;              ///< true speed / the speed odometry reports
  double command_lag_s = 0.0;            ///< the robot follows each odometry row this much after its stamp
  /// Landmarks in pairs 0.3 m apart (subject 6 + 2k and 7 + 2k), both sighted in one frame; with
  /// pairs_share_errors the pair has one Gauss–Markov error per robot, otherwise each landmark its own.
  bool paired_landmarks = false;
  bool pairs_share_errors = false;
  double range_bias_per_rad2 = 0.0;  ///< every range reads this × (its measured bearing)² longer
  double robot_range_bias_m = 0.0;   ///< and a robot's this much longer still
};

constexpr double kStartS = 1000.0;
constexpr double kRowS = 0.02;      // odometry and groundtruth rows
constexpr double kSightingS = 0.2;  // per robot
constexpr double kDurationS = 300.0;
constexpr int kLandmarks = 15;

/// A robot's true track: pose and command at each row (the command holds until the next row).
struct TrueTrack {
  std::vector<MrclamDataset::TimedPose> poses;
  std::vector<std::array<double, 2>> commands;  ///< v, ω
  [[nodiscard]] MrclamDataset::TimedPose at(double t) const {
    const auto i = std::min(poses.size() - 1, static_cast<std::size_t>(std::floor((t - kStartS) / kRowS)));
    return advance(poses[i], commands[i], t - poses[i].time_s);
  }
  static MrclamDataset::TimedPose advance(MrclamDataset::TimedPose p, const std::array<double, 2>& c,
                                          double dt) {
    const double half = 0.5 * c[1] * dt;
    const double chord = std::abs(half) < 1e-12 ? c[0] * dt : c[0] * dt * std::sin(half) / half;
    p.position_m += chord * Vec2(std::cos(p.heading_rad + half), std::sin(p.heading_rad + half));
    p.heading_rad = models::wrap_angle(p.heading_rad + 2.0 * half);
    p.time_s += dt;
    return p;
  }
};

TrueTrack drive(std::mt19937& rng, Vec2 start) {
  std::uniform_real_distribution<double> speed(0.05, 0.4), turn(-0.6, 0.6), heading(-3.0, 3.0);
  TrueTrack track;
  MrclamDataset::TimedPose pose{kStartS, start, heading(rng)};
  std::array<double, 2> command{};
  const auto rows = static_cast<int>(kDurationS / kRowS);
  for (int k = 0; k <= rows; ++k) {
    if (k % 50 == 0) command = {speed(rng), turn(rng)};  // a new command every second
    pose.time_s = kStartS + k * kRowS;
    track.poses.push_back(pose);
    track.commands.push_back(command);
    pose = TrueTrack::advance(pose, command, kRowS);
  }
  return track;
}

/// Odometry reports the true command plus white noise of density v_std, omega_std (variance σ²/dt per
/// row, so a row adds σ²·dt to distance and turn).
void add_odometry(MrclamDataset::Robot& robot, const TrueTrack& track, const SyntheticNoise& noise,
                  std::mt19937& rng) {
  std::normal_distribution<double> unit(0.0, 1.0);
  const double per_row = 1.0 / std::sqrt(kRowS);
  for (std::size_t k = 0; k < track.poses.size(); ++k) {
    robot.groundtruth.push_back(track.poses[k]);
    robot.odometry.push_back({track.poses[k].time_s - noise.command_lag_s,
                              track.commands[k][0] / noise.speed_scale + noise.v_std * per_row * unit(rng),
                              track.commands[k][1] + noise.omega_std * per_row * unit(rng)});
  }
}

/// One channel's Gauss–Markov error for one (robot, subject), sampled exactly at its sightings: over a gap
/// Δt it keeps exp(−Δt/τ) of its value and draws the rest, so its variance stays std² and two sightings
/// Δt apart correlate by exp(−Δt/τ). The first sighting draws from the stationary distribution.
class GaussMarkovError {
 public:
  double at(double time_s, double tau_s, double std, std::mt19937& rng) {
    const double keep = seen_ ? std::exp(-(time_s - last_s_) / tau_s) : 0.0;
    value_ = keep * value_ + std::sqrt(1.0 - keep * keep) * std * unit_(rng);
    last_s_ = time_s;
    seen_ = true;
    return value_;
  }

 private:
  std::normal_distribution<double> unit_{0.0, 1.0};
  double value_ = 0.0;
  double last_s_ = 0.0;
  bool seen_ = false;
};

/// The range and bearing errors of one sighting: white, plus the Gauss–Markov part when it is on (drawn
/// after the white part, so all-white datasets keep the random sequence of the original generator).
class SightingErrors {
 public:
  explicit SightingErrors(const SyntheticNoise& noise) : noise_(noise) {}
  std::array<double, 2> draw(int robot, int subject, double time_s, std::mt19937& rng) {
    const double range_white = std::sqrt(1.0 - noise_.range_correlated_fraction) * noise_.range_std_m;
    const double bearing_white = std::sqrt(1.0 - noise_.bearing_correlated_fraction) * noise_.bearing_std_rad;
    std::array<double, 2> error{range_white * unit_(rng), bearing_white * unit_(rng)};
    if (noise_.correlation_time_s <= 0.0) return error;
    auto& state = states_[{robot, subject}];
    const double tau = noise_.correlation_time_s;
    error[0] +=
        state[0].at(time_s, tau, std::sqrt(noise_.range_correlated_fraction) * noise_.range_std_m, rng);
    error[1] +=
        state[1].at(time_s, tau, std::sqrt(noise_.bearing_correlated_fraction) * noise_.bearing_std_rad, rng);
    return error;
  }

 private:
  const SyntheticNoise& noise_;
  std::normal_distribution<double> unit_{0.0, 1.0};
  std::map<std::pair<int, int>, std::array<GaussMarkovError, 2>> states_;
};

MrclamDataset synthetic_dataset(const SyntheticNoise& noise, unsigned seed = 39) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> area(-5.0, 5.0), unit_interval(0.0, 1.0);
  MrclamDataset data;
  for (int l = 0; l < kLandmarks; ++l) {
    const bool partner = noise.paired_landmarks && l % 2 == 1;
    const Vec2 at =
        partner ? Vec2(data.landmarks.at(5 + l).position_m + Vec2(0.3, 0.0)) : Vec2(area(rng), area(rng));
    data.landmarks[6 + l] = {at, Vec2::Zero()};
  }
  std::vector<TrueTrack> tracks;
  data.robots.resize(kMrclamRobots);
  for (int r = 0; r < kMrclamRobots; ++r) {
    tracks.push_back(drive(rng, Vec2(area(rng), area(rng))));
    add_odometry(data.robots[static_cast<std::size_t>(r)], tracks.back(), noise, rng);
  }
  std::uniform_int_distribution<int> landmark(6, 5 + kLandmarks), robot(1, kMrclamRobots);
  SightingErrors errors(noise);
  for (int r = 0; r < kMrclamRobots; ++r) {
    // Mid-row timestamps, so the groundtruth is interpolated; every direction, bearings near ±π too.
    for (double t = kStartS + 0.01; t < kStartS + kDurationS; t += kSightingS) {
      const auto self = tracks[static_cast<std::size_t>(r)].at(t);
      int subject = unit_interval(rng) < 0.8 ? landmark(rng) : robot(rng);
      if (subject == r + 1) continue;
      const Vec2 target = subject > kMrclamRobots
                              ? data.landmarks.at(subject).position_m
                              : tracks[static_cast<std::size_t>(subject - 1)].at(t).position_m;
      const Vec2 d = target - self.position_m;
      const bool pair = noise.paired_landmarks && subject > kMrclamRobots && subject - 6 + 1 < kLandmarks;
      const int first = pair ? subject - (subject - 6) % 2 : subject;
      const int stream = pair && noise.pairs_share_errors ? first : subject;
      const auto error = errors.draw(r, stream, t, rng);
      const double bias = noise.range_bias_m + (r - 2) * noise.robot_range_bias_step_m;
      const double bearing = models::wrap_angle(std::atan2(d.y(), d.x()) - self.heading_rad + error[1]);
      const double range = d.norm() + bias + error[0] + noise.range_bias_per_rad2 * bearing * bearing +
                           (subject > kMrclamRobots ? 0.0 : noise.robot_range_bias_m);
      if (pair) {  // the partner in the same frame, with the pair's error or its own
        const int other = first == subject ? subject + 1 : first;
        const Vec2 d_other = data.landmarks.at(other).position_m - self.position_m;
        // Drawn at the same time: the same Gauss–Markov value when the stream is shared, a new white part.
        const auto other_error = errors.draw(r, noise.pairs_share_errors ? first : other, t, rng);
        data.robots[static_cast<std::size_t>(r)].measurements.push_back(
            {t, other, d_other.norm() + bias + other_error[0],
             models::wrap_angle(std::atan2(d_other.y(), d_other.x()) - self.heading_rad + other_error[1])});
      }
      if (unit_interval(rng) < noise.misidentified) subject = 6 + (subject + 3) % kLandmarks;  // another one
      data.robots[static_cast<std::size_t>(r)].measurements.push_back({t, subject, range, bearing});
    }
  }
  return data;
}

const OdometryCalibration& window_of(const RobotCalibration& c, double window_s) {
  for (const auto& w : c.odometry) {
    if (w.window_s == window_s) return w;
  }
  throw std::out_of_range("no such window");
}

TEST(MrclamCalibration, RecoversTheKnownSightingNoiseAndBias) {
  const SyntheticNoise noise;
  const auto c = calibrate_mrclam(synthetic_dataset(noise));
  const auto& landmarks = c.pooled.landmarks;
  EXPECT_GT(landmarks.range_m.samples, 5000U);
  // A constant bias is the constant term of the bias across the image, removed before the figures.
  EXPECT_NEAR(c.range_bias.constant_m, noise.range_bias_m, 0.01);
  EXPECT_NEAR(c.range_bias.per_rad2, 0.0, 0.01);
  EXPECT_NEAR(landmarks.range_m.bias, 0.0, 0.01);
  EXPECT_NEAR(landmarks.range_m.std, noise.range_std_m, 0.1 * noise.range_std_m);
  EXPECT_NEAR(landmarks.bearing_rad.bias, 0.0, 0.003);
  EXPECT_NEAR(landmarks.bearing_rad.std, noise.bearing_std_rad, 0.1 * noise.bearing_std_rad);
  // Clean Gaussian data: the filters' gate (χ² 13.8) drops 0.1 %, a 3σ box per channel would drop 0.54 %;
  // a bearing residual not wrapped at ±π would add every sighting straddling the robot's back (about 2 %).
  EXPECT_LT(landmarks.range_m.outlier_fraction(), 0.003);
  const auto& robots = c.pooled.robots;
  EXPECT_GT(robots.range_m.samples, 1000U);
  EXPECT_NEAR(robots.range_m.bias, 0.0, 0.02);  // robots read as long as landmarks
  EXPECT_NEAR(robots.range_m.std, noise.range_std_m, 0.15 * noise.range_std_m);
  EXPECT_NEAR(robots.bearing_rad.std, noise.bearing_std_rad, 0.15 * noise.bearing_std_rad);
  // The noise does not grow with range: the fitted slope is near zero.
  EXPECT_NEAR(landmarks.range_std_slope, 0.0, 0.01);
  EXPECT_NEAR(landmarks.range_std_intercept_m, noise.range_std_m, 0.02);
}

TEST(MrclamCalibration, SightingsAreTrimmedByThePoseFiltersGateNotByABoxPerChannel) {
  // A sighting 3.2 σ off in range alone passes the gate (χ² 10.2 < 13.8), so a filter uses it and the
  // figures must describe it; 2.9 σ off in both channels (χ² 16.8) is refused by the gate.
  const auto gate = CalibrationOptions{}.sighting_trim();
  EXPECT_EQ(gate.shape, PairTrim::Shape::joint);
  EXPECT_EQ(gate.threshold, 13.8);
  EXPECT_TRUE(gate.inside(3.2, 0.0));
  EXPECT_TRUE(gate.inside(0.0, -3.2));
  EXPECT_FALSE(gate.inside(2.9, -2.9));
  const auto box = CalibrationOptions{}.odometry_trim();
  EXPECT_FALSE(box.inside(3.2, 0.0));
  EXPECT_TRUE(box.inside(2.9, -2.9));
}

TEST(MrclamCalibration, EitherTrimRecoversTheStdOfAGaussianPairFromItsInliers) {
  // Tight trims, so that the correction for the cut tails is large: χ² 4 keeps 86 % of a Gaussian pair and
  // its inliers' raw std is 0.83 σ; a ±1.5 σ box keeps 75 % and 0.74 σ.
  std::mt19937 rng(11);
  std::normal_distribution<double> unit(0.0, 1.0);
  std::vector<std::array<double, 2>> residuals;
  for (int i = 0; i < 40000; ++i) residuals.push_back({0.02 + 0.05 * unit(rng), -0.003 + 0.01 * unit(rng)});
  for (const auto trim : {PairTrim::joint(4.0), PairTrim::per_channel(1.5)}) {
    const auto stats = robust_pair_stats(residuals, trim);
    EXPECT_NEAR(stats[0].std, 0.05, 0.03 * 0.05);
    EXPECT_NEAR(stats[1].std, 0.01, 0.03 * 0.01);
    EXPECT_NEAR(stats[0].bias, 0.02, 0.002);
    const double kept = trim.shape == PairTrim::Shape::joint ? 1.0 - std::exp(-2.0) : std::pow(0.8664, 2);
    EXPECT_NEAR(stats[0].outlier_fraction(), 1.0 - kept, 0.01);
  }
}

TEST(MrclamCalibration, RecoversTheGaussMarkovCorrelationOfConsecutiveSightings) {
  SyntheticNoise noise;
  noise.correlation_time_s = 4.0;
  noise.range_correlated_fraction = 0.7;
  noise.bearing_correlated_fraction = 0.4;
  // Robots' range biases 0.1 m apart (σ 0.1 m): left in, they would read as a correlation that never decays.
  noise.robot_range_bias_step_m = 0.05;
  const auto correlated = calibrate_mrclam(synthetic_dataset(noise)).pooled.landmarks.correlation;
  // Each landmark is seen every 3.75 s on average per robot: thousands of pairs, a few hundred per bin.
  EXPECT_GT(correlated.pairs, 5000U);
  EXPECT_NEAR(correlated.correlation_time_s, noise.correlation_time_s, 0.3 * noise.correlation_time_s);
  EXPECT_NEAR(correlated.range_fraction, noise.range_correlated_fraction, 0.1);
  EXPECT_NEAR(correlated.bearing_fraction, noise.bearing_correlated_fraction, 0.1);

  // White errors with the same robot biases: nothing left to correlate.
  noise.correlation_time_s = 0.0;
  noise.range_correlated_fraction = noise.bearing_correlated_fraction = 0.0;
  const auto white = calibrate_mrclam(synthetic_dataset(noise)).pooled.landmarks.correlation;
  EXPECT_LT(white.range_fraction, 0.1);
  EXPECT_LT(white.bearing_fraction, 0.1);
}

TEST(MrclamCalibration, RecoversTheOdometryDensitiesAtEveryWindowLength) {
  const SyntheticNoise noise;
  const auto c = calibrate_mrclam(synthetic_dataset(noise));
  for (double window : {0.5, 1.0, 2.0}) {
    SCOPED_TRACE(window);
    const auto& w = window_of(c.pooled, window);
    EXPECT_GT(w.distance_m.samples, static_cast<std::size_t>(4.0 * kDurationS / window));
    // The √s model: the same density from every window length (a variance divided by window² would
    // give 1/√window times the density).
    EXPECT_NEAR(w.v_std(), noise.v_std, 0.1 * noise.v_std);
    EXPECT_NEAR(w.omega_std(), noise.omega_std, 0.1 * noise.omega_std);
    EXPECT_NEAR(w.v_std_with_tails(), noise.v_std, 0.1 * noise.v_std);  // the published figure
    EXPECT_NEAR(w.omega_std_with_tails(), noise.omega_std, 0.1 * noise.omega_std);
    EXPECT_NEAR(w.distance_ratio, 1.0, 0.01);
    EXPECT_NEAR(w.distance_m.bias, 0.0, 0.005);
  }
}

TEST(MrclamCalibration, MeasuresTheCommandLagAndScoresTheOdometryWithIt) {
  SyntheticNoise noise;
  noise.command_lag_s = 0.2;
  const auto c = calibrate_mrclam(synthetic_dataset(noise));
  EXPECT_NEAR(c.odometry_lag.lag_s, noise.command_lag_s, 0.03);
  ASSERT_FALSE(c.odometry_lag.curve.empty());
  EXPECT_NEAR(c.odometry_lag.curve.back()[0], kMaxLagS, 1e-9);
  // Scored with the lag, the windows see only the white noise again.
  const auto& w = window_of(c.pooled, 1.0);
  EXPECT_NEAR(w.omega_std(), noise.omega_std, 0.1 * noise.omega_std);
  EXPECT_NEAR(w.v_std(), noise.v_std, 0.1 * noise.v_std);

  const auto prompt = calibrate_mrclam(synthetic_dataset(SyntheticNoise{}));
  EXPECT_LE(prompt.odometry_lag.lag_s, 0.03);
}

TEST(MrclamCalibration, PublishedOdometryCoversTheErrorOverTheSightingsCorrelationTime) {
  // Odometry 10 % fast: over a window of W seconds the distance error has a mean −0.1·v·W besides the
  // white part. Sightings correlated over τ = 4 s: the filters get news about once per τ, so the published
  // density is the RMS (mean included) over windows of τ: √(v_std² + 0.1²·E[v²]·τ) for speeds uniform in
  // [0.05, 0.4] m/s, E[v²] = 0.0609 m²/s².
  SyntheticNoise noise;
  noise.speed_scale = 0.9;
  noise.correlation_time_s = 4.0;
  noise.range_correlated_fraction = 0.7;
  noise.bearing_correlated_fraction = 0.4;
  const auto c = calibrate_mrclam(synthetic_dataset(noise));
  const auto& horizon = c.pooled.horizon;
  EXPECT_NEAR(horizon.window_s, c.pooled.landmarks.correlation.correlation_time_s, 0.05);
  EXPECT_NEAR(horizon.window_s, noise.correlation_time_s, 0.3 * noise.correlation_time_s);
  EXPECT_GT(horizon.distance_m.samples, 4.0 * kDurationS / horizon.window_s);
  const double mean_square_speed = (0.4 * 0.4 * 0.4 - 0.05 * 0.05 * 0.05) / (3.0 * 0.35);
  const double expected =
      std::sqrt(noise.v_std * noise.v_std + 0.1 * 0.1 * mean_square_speed * horizon.window_s);
  EXPECT_NEAR(horizon.v_rms_with_tails(), expected, 0.1 * expected);
  // Its std alone (the mean left out) is well short of it: the scale error is error the filter carries.
  EXPECT_LT(horizon.v_std_with_tails(), 0.8 * expected);
  EXPECT_NEAR(horizon.omega_rms_with_tails(), noise.omega_std, 0.15 * noise.omega_std);
  for (const auto& robot : c.robots) EXPECT_EQ(robot.horizon.window_s, horizon.window_s);

  // Independent sightings: the horizon is the 1 s floor.
  noise.correlation_time_s = 0.0;
  noise.range_correlated_fraction = noise.bearing_correlated_fraction = 0.0;
  EXPECT_EQ(calibrate_mrclam(synthetic_dataset(noise)).pooled.horizon.window_s, 1.0);
}

TEST(MrclamCalibration, LandmarksWhoseErrorsMoveTogetherInOneFrameAreOneCluster) {
  // Landmarks in pairs 0.3 m apart, sighted together. One Gauss–Markov error per pair (70 % of the range
  // variance): the same-frame range correlation reads about 0.7 in the 0.25–0.5 m bin, so the cluster
  // radius is that bin's upper edge. Each landmark with its own error: no correlation, no cluster.
  SyntheticNoise noise;
  noise.correlation_time_s = 4.0;
  noise.range_correlated_fraction = 0.7;
  noise.bearing_correlated_fraction = 0.4;
  noise.paired_landmarks = true;
  noise.pairs_share_errors = true;
  const auto shared = calibrate_mrclam(synthetic_dataset(noise)).pooled.landmarks;
  ASSERT_GE(shared.same_frame.size(), 2U);
  EXPECT_GT(shared.same_frame[1].pairs, 1000U);
  EXPECT_NEAR(shared.same_frame[1].range_rho, 0.7, 0.1);
  EXPECT_NEAR(shared.same_frame[1].bearing_rho, 0.4, 0.1);
  EXPECT_EQ(shared.cluster_radius_m, 0.5);

  noise.pairs_share_errors = false;
  const auto separate = calibrate_mrclam(synthetic_dataset(noise)).pooled.landmarks;
  EXPECT_LT(std::abs(separate.same_frame[1].range_rho), 0.1);
  EXPECT_EQ(separate.cluster_radius_m, 0.0);
}

TEST(MrclamCalibration, TheRangeBiasAcrossTheImageIsFittedAndRemovedBeforeEveryFigure) {
  // Ranges read 0.2·β² m longer at bearing β (0.2 m at the edge of a ±1 rad view, against σ = 0.1 m),
  // robots' 0.05 m longer still. The fit gives the curve back, and the figures are the sensor's without it.
  SyntheticNoise noise;
  noise.range_bias_per_rad2 = 0.2;
  noise.robot_range_bias_m = 0.05;
  const auto c = calibrate_mrclam(synthetic_dataset(noise));
  EXPECT_NEAR(c.range_bias.per_rad2, 0.2, 0.02);
  EXPECT_NEAR(c.range_bias.constant_m, noise.range_bias_m, 0.01);
  EXPECT_NEAR(c.range_bias.per_rad, 0.0, 0.01);
  EXPECT_GT(c.range_bias.std_before_m, 1.1 * noise.range_std_m);
  EXPECT_NEAR(c.range_bias.std_after_m, noise.range_std_m, 0.1 * noise.range_std_m);
  EXPECT_NEAR(c.pooled.landmarks.range_m.std, noise.range_std_m, 0.1 * noise.range_std_m);
  EXPECT_NEAR(c.pooled.landmarks.range_m.bias, 0.0, 0.01);
  EXPECT_NEAR(c.pooled.robots.range_m.bias, noise.robot_range_bias_m, 0.015);
}

TEST(MrclamCalibration, MisidentifiedBarcodesAreTrimmedNotScored) {
  SyntheticNoise noise;
  const auto clean = calibrate_mrclam(synthetic_dataset(noise)).pooled.landmarks;
  noise.misidentified = 0.05;
  const auto dirty = calibrate_mrclam(synthetic_dataset(noise)).pooled.landmarks;
  // Most misidentified sightings land metres off and are trimmed; the few that land near the true
  // landmark's range and bearing stay, so the std moves by a few per cent at most (an untrimmed std is 20×).
  EXPECT_NEAR(dirty.range_m.std, clean.range_m.std, 0.05 * clean.range_m.std);
  EXPECT_NEAR(dirty.bearing_rad.std, clean.bearing_rad.std, 0.05 * clean.bearing_rad.std);
  EXPECT_NEAR(dirty.range_m.bias, clean.range_m.bias, 0.01);
  EXPECT_GT(dirty.range_m.outlier_fraction(), clean.range_m.outlier_fraction() + 0.035);
  EXPECT_LT(dirty.range_m.outlier_fraction(), clean.range_m.outlier_fraction() + 0.055);
}

TEST(MrclamCalibration, AGroundtruthGapIsSkippedNotScored) {
  const SyntheticNoise noise;
  auto data = synthetic_dataset(noise);
  const double gap_from = kStartS + 100.0;
  const double gap_to = kStartS + 103.0;
  auto& track = data.robots[0].groundtruth;
  std::erase_if(track, [&](const auto& pose) { return pose.time_s > gap_from && pose.time_s < gap_to; });
  std::size_t landmark_sightings_in_gap = 0;
  for (const auto& m : data.robots[0].measurements) {
    if (m.subject > kMrclamRobots && m.time_s > gap_from && m.time_s < gap_to) ++landmark_sightings_in_gap;
  }
  ASSERT_GT(landmark_sightings_in_gap, 5U);
  const auto c = calibrate_mrclam(data);
  EXPECT_EQ(c.robots[0].landmarks.skipped_gap, landmark_sightings_in_gap);
  EXPECT_EQ(c.robots[1].landmarks.skipped_gap, 0U);
  EXPECT_GT(c.robots[0].robots.skipped_gap + c.robots[1].robots.skipped_gap, 0U);  // robot 1 seen in its gap
  // Windows of 1 s touching the 3 s gap: three or four, depending on where the tiling falls.
  const auto& window = window_of(c.robots[0], 1.0);
  EXPECT_GE(window.skipped_gap, 3U);
  EXPECT_LE(window.skipped_gap, 4U);
  EXPECT_NEAR(window.v_std(), noise.v_std, 0.15 * noise.v_std);
}

TEST(MrclamCalibration, BearingsStraddlingTheRobotsBackAreWrapped) {
  // Five robots standing still facing +x, robot 1 sighting a landmark straight behind it (bearing π):
  // about half the noisy bearings read near −π. Unwrapped, those residuals would be ≈ −2π.
  MrclamDataset data;
  data.landmarks[6] = {Vec2(-3.0, 0.0), Vec2::Zero()};
  data.robots.resize(kMrclamRobots);
  std::mt19937 rng(7);
  std::normal_distribution<double> bearing_noise(0.0, 0.03);
  for (int r = 0; r < kMrclamRobots; ++r) {
    auto& robot = data.robots[static_cast<std::size_t>(r)];
    for (int k = 0; k <= 3000; ++k) {
      const double t = kStartS + k * kRowS;
      robot.groundtruth.push_back({t, Vec2(0.0, 10.0 * r), 0.0});
      robot.odometry.push_back({t, 0.0, 0.0});
      if (r == 0 && k % 5 == 1) {
        robot.measurements.push_back({t, 6, 3.0, models::wrap_angle(std::numbers::pi + bearing_noise(rng))});
      }
    }
  }
  const auto c = calibrate_mrclam(data).pooled.landmarks;
  EXPECT_EQ(c.bearing_rad.samples, 600U);
  EXPECT_NEAR(c.bearing_rad.bias, 0.0, 0.005);
  EXPECT_NEAR(c.bearing_rad.std, 0.03, 0.004);
  EXPECT_LT(c.bearing_rad.outlier_fraction(), 0.02);
}

TEST(MrclamCalibration, GroundtruthIsInterpolatedOnlyBetweenCloseRows) {
  const std::vector<MrclamDataset::TimedPose> track{
      {10.0, Vec2(0, 0), 3.1}, {10.05, Vec2(1, 0), -3.1}, {11.0, Vec2(2, 0), 0.0}};
  const auto middle = groundtruth_at(track, 10.025, 0.1);
  ASSERT_TRUE(middle.has_value());
  EXPECT_NEAR(middle->position_m.x(), 0.5, 1e-12);
  EXPECT_NEAR(std::abs(middle->heading_rad), std::numbers::pi, 1e-9);  // through ±π, not through 0
  EXPECT_FALSE(groundtruth_at(track, 10.5, 0.1).has_value());          // rows 0.95 s apart
  EXPECT_FALSE(groundtruth_at(track, 9.9, 0.1).has_value());
  EXPECT_FALSE(groundtruth_at(track, 11.1, 0.1).has_value());
  EXPECT_TRUE(groundtruth_at(track, 11.0, 0.1).has_value());
}

}  // namespace
}  // namespace swarmloc::world
