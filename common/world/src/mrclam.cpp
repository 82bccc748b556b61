#include "swarmloc/world/mrclam.hpp"

#include <zlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>
#include <string>

#include "swarmloc/estimators/pose/centralized_pose_ekf.hpp"
#include "swarmloc/estimators/pose/dead_reckoning.hpp"
#include "swarmloc/models/measurement_models.hpp"
#include "swarmloc/world/metrics.hpp"
#include "swarmloc/world/pose_smoother.hpp"

namespace swarmloc::world {
namespace {

using config::ScenarioError;

/// The whole text of NAME.dat or NAME.dat.gz in `directory` (zlib reads both).
std::string read_data_file(const std::filesystem::path& directory, const std::string& name) {
  std::filesystem::path path = directory / (name + ".dat");
  if (!std::filesystem::exists(path)) path += ".gz";
  if (!std::filesystem::exists(path)) {
    throw ScenarioError("world.data_dir: '" + directory.string() + "' has no " + name + ".dat or " + name +
                        ".dat.gz (is it a UTIAS MRCLAM dataset directory?)");
  }
  gzFile file = gzopen(path.c_str(), "rb");
  if (file == nullptr) throw ScenarioError("world.data_dir: cannot open '" + path.string() + "'");
  std::string text;
  char buffer[1 << 16];
  int got = 0;
  while ((got = gzread(file, buffer, sizeof buffer)) > 0) text.append(buffer, static_cast<std::size_t>(got));
  const bool failed = got < 0;
  gzclose(file);
  if (failed) throw ScenarioError("world.data_dir: '" + path.string() + "' is not readable gzip or text");
  return text;
}

/// Rows of `columns` finite numbers; '#' lines and blank lines skipped.
std::vector<std::vector<double>> parse_rows(const std::string& text, std::size_t columns,
                                            const std::string& name) {
  std::vector<std::vector<double>> rows;
  std::istringstream in(text);
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream fields(line);
    std::vector<double> row(columns);
    for (auto& value : row) {
      if (!(fields >> value) || !std::isfinite(value)) {
        throw ScenarioError("world.data_dir: " + name + " line " + std::to_string(line_number) +
                            ": expected " + std::to_string(columns) + " finite numbers");
      }
    }
    rows.push_back(std::move(row));
  }
  return rows;
}

void require_increasing_times(const std::vector<double>& times, const std::string& name) {
  for (std::size_t k = 1; k < times.size(); ++k) {
    if (times[k] < times[k - 1]) {
      throw ScenarioError("world.data_dir: " + name + " row " + std::to_string(k + 1) +
                          ": time goes backwards");
    }
  }
}

}  // namespace

MrclamDataset load_mrclam(const std::filesystem::path& directory) {
  MrclamDataset data;
  std::map<int, int> subject_of_barcode;
  for (const auto& row : parse_rows(read_data_file(directory, "Barcodes"), 2, "Barcodes")) {
    subject_of_barcode[static_cast<int>(row[1])] = static_cast<int>(row[0]);
  }
  for (const auto& row :
       parse_rows(read_data_file(directory, "Landmark_Groundtruth"), 5, "Landmark_Groundtruth")) {
    data.landmarks[static_cast<int>(row[0])] = {Vec2(row[1], row[2]), Vec2(row[3], row[4])};
  }
  data.robots.resize(kMrclamRobots);
  double latest_first = -1e300;
  double earliest_last = 1e300;
  for (int r = 0; r < kMrclamRobots; ++r) {
    auto& robot = data.robots[static_cast<std::size_t>(r)];
    const std::string prefix = "Robot" + std::to_string(r + 1) + "_";
    std::vector<double> times;
    for (const auto& row :
         parse_rows(read_data_file(directory, prefix + "Groundtruth"), 4, prefix + "Groundtruth")) {
      robot.groundtruth.push_back({row[0], Vec2(row[1], row[2]), row[3]});
      times.push_back(row[0]);
    }
    require_increasing_times(times, prefix + "Groundtruth");
    times.clear();
    for (const auto& row :
         parse_rows(read_data_file(directory, prefix + "Odometry"), 3, prefix + "Odometry")) {
      robot.odometry.push_back({row[0], row[1], row[2]});
      times.push_back(row[0]);
    }
    require_increasing_times(times, prefix + "Odometry");
    times.clear();
    for (const auto& row :
         parse_rows(read_data_file(directory, prefix + "Measurement"), 4, prefix + "Measurement")) {
      const auto subject = subject_of_barcode.find(static_cast<int>(row[1]));
      if (subject == subject_of_barcode.end() || subject->second == r + 1) {
        ++data.unknown_barcodes;
        continue;
      }
      if (subject->second > kMrclamRobots && !data.landmarks.contains(subject->second)) {
        ++data.unknown_barcodes;
        continue;
      }
      robot.measurements.push_back({row[0], subject->second, row[2], row[3]});
      times.push_back(row[0]);
    }
    require_increasing_times(times, prefix + "Measurement");
    if (robot.groundtruth.size() < 2 || robot.odometry.empty()) {
      throw ScenarioError("world.data_dir: " + prefix + "Groundtruth/Odometry hold too few rows");
    }
    latest_first = std::max(latest_first, robot.groundtruth.front().time_s);
    earliest_last = std::min(earliest_last, robot.odometry.back().time_s);
  }
  if (!(earliest_last > latest_first)) {
    throw ScenarioError("world.data_dir: the robots' groundtruth and odometry share no time window");
  }
  data.start_time_s = latest_first;
  data.end_time_s = earliest_last;
  return data;
}

MrclamSteps::MrclamSteps(std::shared_ptr<const MrclamDataset> data, const config::Scenario& scenario)
    : data_(std::move(data)),
      step_s_(scenario.world.data_step_s),
      steps_(static_cast<std::int64_t>(std::floor((data_->end_time_s - data_->start_time_s) / step_s_)) + 1),
      range_noise_(scenario.noise),
      bearing_std_rad_(scenario.noise.bearing_std_rad),
      odometry_v_std_(scenario.noise.odometry_v_std),
      odometry_omega_std_(scenario.noise.odometry_omega_std),
      odometry_lag_s_(scenario.noise.odometry_lag_s) {}

MrclamDataset::TimedPose MrclamSteps::pose_at(AgentId agent, std::int64_t step) const {
  const auto& track = data_->robots.at(static_cast<std::size_t>(agent)).groundtruth;
  const double t = data_->start_time_s + time_of(step);
  const auto after =
      std::lower_bound(track.begin(), track.end(), t,
                       [](const MrclamDataset::TimedPose& pose, double time) { return pose.time_s < time; });
  if (after == track.begin()) return {t, track.front().position_m, track.front().heading_rad};
  if (after == track.end()) {
    // Past this robot's groundtruth (Dataset 6: robot 1's ends at 772 s of 900 s): unknown truth,
    // which scoring counts as missing rather than guess.
    if (t > track.back().time_s + 1e-9) {
      const double nan = std::numeric_limits<double>::quiet_NaN();
      return {t, Vec2(nan, nan), nan};
    }
    return {t, track.back().position_m, track.back().heading_rad};
  }
  const auto before = std::prev(after);
  const double span = after->time_s - before->time_s;
  if (step > 0 && span > kMrclamMaxTruthGapS) {
    // Inside a gap in the groundtruth (the motion capture lost the robot): unknown truth, not a guess.
    const double nan = std::numeric_limits<double>::quiet_NaN();
    return {t, Vec2(nan, nan), nan};
  }
  const double w = span > 0.0 ? (t - before->time_s) / span : 0.0;
  const double turn = models::wrap_angle(after->heading_rad - before->heading_rad);
  return {t, (1.0 - w) * before->position_m + w * after->position_m,
          models::wrap_angle(before->heading_rad + w * turn)};
}

std::vector<Vec2> MrclamSteps::truth(std::int64_t step) const {
  std::vector<Vec2> positions;
  positions.reserve(static_cast<std::size_t>(kMrclamRobots));
  for (AgentId i = 0; i < kMrclamRobots; ++i) positions.push_back(pose_at(i, step).position_m);
  return positions;
}

estimators::MeasurementBatch MrclamSteps::batch(AgentId agent, std::int64_t step) const {
  estimators::MeasurementBatch batch;
  if (step < 0 || step >= steps_ || agent < 0 || agent >= kMrclamRobots) return batch;
  batch.world_step = step;
  batch.world_time_s = time_of(step);
  for (AgentId j = 0; j < kMrclamRobots; ++j) {
    if (j != agent) batch.neighbours.push_back(j);
  }
  if (step == 0) return batch;  // the prior is the groundtruth pose at t_0
  const auto& robot = data_->robots[static_cast<std::size_t>(agent)];
  const double from = data_->start_time_s + time_of(step - 1);
  const double to = data_->start_time_s + time_of(step);

  // Odometry: each row's command holds from its time until the next row's (the first row's from t_0); the
  // robot moves by it odometry_lag_s later.
  estimators::OdometryInput odometry;
  odometry.v_std = odometry_v_std_;
  odometry.omega_std = odometry_omega_std_;
  const auto& rows = robot.odometry;
  const double command_from = from - odometry_lag_s_;
  const double command_to = to - odometry_lag_s_;
  auto row =
      std::upper_bound(rows.begin(), rows.end(), command_from,
                       [](double time, const MrclamDataset::OdometryRow& r) { return time < r.time_s; });
  if (row != rows.begin()) --row;  // the command in force at `command_from`
  for (; row != rows.end() && row->time_s < command_to; ++row) {
    const double begin = std::max(command_from, row->time_s);
    const double end =
        std::next(row) == rows.end() ? command_to : std::min(command_to, std::next(row)->time_s);
    if (end > begin) odometry.segments.push_back({row->v_mps, row->omega_radps, end - begin});
  }
  batch.odometry = std::move(odometry);

  const auto& measurements = robot.measurements;
  auto m =
      std::upper_bound(measurements.begin(), measurements.end(), from,
                       [](double time, const MrclamDataset::MeasurementRow& r) { return time < r.time_s; });
  for (; m != measurements.end() && m->time_s <= to; ++m) {
    estimators::RangeBearingMeasurement measurement;
    measurement.range_m = m->range_m - range_bias_at(m->bearing_rad);
    measurement.bearing_rad = m->bearing_rad;
    measurement.range_std_m = range_noise_.range_std_at(measurement.range_m);
    measurement.bearing_std_rad = bearing_std_rad_;
    measurement.age_s = to - m->time_s;
    if (m->subject <= kMrclamRobots) {
      measurement.range_m -= range_noise_.robot_range_bias_m;
      measurement.peer = m->subject - 1;
    } else {
      const auto& landmark = data_->landmarks.at(m->subject);
      measurement.landmark = true;
      measurement.peer = m->subject;
      measurement.landmark_m = landmark.position_m;
      measurement.landmark_cov = landmark.std_m.cwiseProduct(landmark.std_m).asDiagonal();
    }
    batch.range_bearings.push_back(measurement);
  }
  return batch;
}

World build_mrclam_world(const config::Scenario& scenario) {
  if (scenario.world.agents != kMrclamRobots) {
    throw ScenarioError("world.agents: UTIAS MRCLAM has " + std::to_string(kMrclamRobots) + " robots");
  }
  auto data = std::make_shared<const MrclamDataset>(load_mrclam(scenario.world.data_dir));
  auto steps = std::make_shared<const MrclamSteps>(data, scenario);
  if (scenario.run.steps > steps->steps()) {
    throw ScenarioError("run.steps: " + std::to_string(scenario.run.steps) + " is more than the dataset's " +
                        std::to_string(steps->steps()) +
                        " steps of world.data_step_s = " + std::to_string(scenario.world.data_step_s) + " s");
  }
  World world;
  world.recorded = steps;
  world.is_anchor.assign(kMrclamRobots, false);
  world.neighbours.resize(kMrclamRobots);
  for (AgentId i = 0; i < kMrclamRobots; ++i) {
    const auto start = steps->pose_at(i, 0);
    world.truth.push_back(start.position_m);
    world.initial_guess.push_back(start.position_m);
    world.initial_heading.push_back(start.heading_rad);
    for (AgentId j = 0; j < kMrclamRobots; ++j) {
      if (j != i) world.neighbours[static_cast<std::size_t>(i)].push_back(j);
    }
    world.clocks.push_back(
        core::draw_clock(scenario.seed, i, scenario.clock.offset_max_s, scenario.clock.drift_ppm));
  }
  return world;
}

namespace {

/// A baseline's error sums over the scored robot-steps of a MRCLAM run.
struct BaselineScore {
  double squared_sum = 0.0;  ///< Σ over scored steps of the step's mean squared error
  double step_sum = 0.0;     ///< this step's Σ of squared errors
  double last_mse = 0.0;
  MeanNees nees;
  MeanNees step_nees;
  MeanNees last_nees;

  void add(const Vec2& position_error, std::optional<double> nees3) {
    step_sum += position_error.squaredNorm();
    step_nees.add(nees3);
  }
  void end_step(int scored) {
    last_mse = step_sum / scored;
    squared_sum += last_mse;
    nees.sum += step_nees.sum;
    nees.count += step_nees.count;
    last_nees = step_nees;
    step_sum = 0.0;
    step_nees = {};
  }
  [[nodiscard]] MrclamBaseline result(std::int64_t scored_steps) const {
    const double n = static_cast<double>(std::max<std::int64_t>(1, scored_steps));
    return {std::sqrt(squared_sum / n), std::sqrt(last_mse), nees.mean(), last_nees.mean()};
  }
};

/// The filters' parameters from the scenario (as the pose_ekf agents read them).
estimators::KalmanFilterParams pose_filter_params(const config::Scenario& scenario) {
  estimators::KalmanFilterParams params;
  params.process_noise_std_m = scenario.algorithm.kalman.process_noise_std_m;
  params.initial_std_m = scenario.algorithm.kalman.initial_std_m;
  params.initial_heading_std_rad = scenario.algorithm.pose.initial_heading_std_rad;
  params.range_bearing_gate_chi2 = scenario.algorithm.pose.range_bearing_gate_chi2;
  params.sighting_correlation_time_s = scenario.noise.sighting_correlation_time_s;
  params.sighting_cluster_radius_m = scenario.noise.sighting_cluster_radius_m;
  params.range_correlated_fraction = scenario.noise.range_correlated_fraction;
  params.bearing_correlated_fraction = scenario.noise.bearing_correlated_fraction;
  return params;
}

/// A 3×3 covariance of an Estimate with a heading (the centralized EKF's marginal).
Mat3 pose_covariance(const estimators::Estimate& estimate) {
  Mat3 covariance = Mat3::Zero();
  covariance.topLeftCorner<2, 2>() = estimate.covariance;
  if (estimate.heading) {
    covariance.block<2, 1>(0, 2) = estimate.heading->position_cov_m_rad;
    covariance.block<1, 2>(2, 0) = estimate.heading->position_cov_m_rad.transpose();
    covariance(2, 2) = estimate.heading->variance_rad2;
  }
  return covariance;
}

Pose pose_of(const estimators::Estimate& estimate) {
  return {estimate.mean_m.x(), estimate.mean_m.y(), estimate.heading ? estimate.heading->heading_rad : 0.0};
}

/// The smoother solved from the centralized EKF's trajectory and scored like the filters.
MrclamSmootherBaseline smoother_baseline(const PoseSmootherProblem& problem,
                                         const std::vector<Pose>& ekf_poses,
                                         const std::vector<Mat3>& ekf_marginals, const World& world) {
  const auto started = std::chrono::steady_clock::now();
  const PoseSmootherSolution solution = solve_pose_smoother(problem, ekf_poses, ekf_marginals);
  MrclamSmootherBaseline baseline;
  baseline.solve_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  BaselineScore score;
  std::int64_t scored_steps = 0;
  const auto robots = static_cast<std::size_t>(problem.robots);
  for (std::int64_t step = 0; step < problem.steps; ++step) {
    const auto truth = world.recorded->truth(step);
    int scored = 0;
    for (std::size_t i = 0; i < robots; ++i) {
      if (!truth[i].allFinite()) continue;
      ++scored;
      const std::size_t k = static_cast<std::size_t>(step) * robots + i;
      const Pose truth_pose(truth[i].x(), truth[i].y(),
                            world.recorded->truth_heading(static_cast<AgentId>(i), step));
      std::optional<double> nees3;
      if (!solution.marginals.empty())
        nees3 = pose_nees(solution.poses[k], solution.marginals[k], truth_pose);
      score.add(solution.poses[k].head<2>() - truth[i], nees3);
    }
    if (scored == 0) continue;
    score.end_step(scored);
    ++scored_steps;
  }
  static_cast<MrclamBaseline&>(baseline) = score.result(scored_steps);
  baseline.iterations = solution.iterations;
  baseline.gating_rounds = solution.gating_rounds;
  baseline.converged = solution.converged;
  baseline.range_bearings_used = solution.range_bearings_used;
  baseline.range_bearings_gated = solution.range_bearings_gated;
  return baseline;
}

}  // namespace

MrclamBaselines mrclam_baselines(const config::Scenario& scenario, const World& world, bool with_smoother) {
  const estimators::KalmanFilterParams params = pose_filter_params(scenario);
  std::vector<estimators::AgentSetup> setups;
  std::vector<std::unique_ptr<estimators::DeadReckoning>> dead_reckoning;
  for (AgentId i = 0; i < world.size(); ++i) {
    setups.push_back(world.setup_of(i));
    dead_reckoning.push_back(std::make_unique<estimators::DeadReckoning>(setups.back(), params));
  }
  estimators::CentralizedPoseEkf centralized(setups, params);
  PoseSmootherProblem problem =
      make_pose_smoother_problem(world.initial_guess, world.initial_heading, params);
  std::vector<Pose> ekf_poses;
  std::vector<Mat3> ekf_marginals;
  BaselineScore dr;
  BaselineScore ekf;
  const std::int64_t steps = scenario.run.steps;
  std::int64_t scored_steps = 0;
  for (std::int64_t step = 0; step < steps; ++step) {
    std::vector<estimators::MeasurementBatch> batches;
    std::vector<const estimators::MeasurementBatch*> pointers;
    batches.reserve(static_cast<std::size_t>(world.size()));
    pointers.reserve(static_cast<std::size_t>(world.size()));
    for (AgentId i = 0; i < world.size(); ++i) batches.push_back(world.recorded->batch(i, step));
    for (const auto& batch : batches) pointers.push_back(&batch);
    centralized.step(pointers);
    if (with_smoother) add_pose_smoother_step(problem, step, batches, params);
    const auto truth = world.recorded->truth(step);
    int scored = 0;
    for (AgentId i = 0; i < world.size(); ++i) {
      const auto k = static_cast<std::size_t>(i);
      estimators::StepInput input;
      input.local_step = step;
      input.measurements = &batches[k];
      (void)dead_reckoning[k]->step(input);
      const estimators::Estimate ekf_estimate = centralized.estimate(i);
      if (with_smoother) {
        ekf_poses.push_back(pose_of(ekf_estimate));
        ekf_marginals.push_back(pose_covariance(ekf_estimate));
      }
      if (!truth[k].allFinite()) continue;  // no groundtruth: not scored (as in metrics' score())
      ++scored;
      const double heading = world.recorded->truth_heading(i, step);
      const estimators::Estimate dr_estimate = dead_reckoning[k]->estimate();
      dr.add(dr_estimate.mean_m - truth[k], pose_nees(dr_estimate, truth[k], heading));
      ekf.add(ekf_estimate.mean_m - truth[k], pose_nees(ekf_estimate, truth[k], heading));
    }
    if (scored == 0) continue;
    dr.end_step(scored);
    ekf.end_step(scored);
    ++scored_steps;
  }
  MrclamBaselines baselines;
  baselines.dead_reckoning = dr.result(scored_steps);
  baselines.centralized_ekf = ekf.result(scored_steps);
  if (with_smoother) baselines.batch_smoother = smoother_baseline(problem, ekf_poses, ekf_marginals, world);
  return baselines;
}

}  // namespace swarmloc::world
