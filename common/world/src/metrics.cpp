#include "swarmloc/world/metrics.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "swarmloc/estimators/crlb.hpp"
#include "swarmloc/models/measurement_models.hpp"
#include "swarmloc/models/multipath.hpp"

namespace swarmloc::world {
namespace {

/// NaN or Inf in the mean, or in a covariance the estimate calls valid.
bool holds_non_finite(const estimators::Estimate& estimate) {
  return !estimate.mean_m.allFinite() || (estimate.valid && !estimate.covariance.allFinite());
}

}  // namespace

namespace {

/// One estimate's error against its truth: its length, whether a covariance it calls valid is broken, and
/// eᵀP⁻¹e for a valid positive definite covariance.
struct AgentError {
  double norm = 0.0;
  bool broken_covariance = false;
  std::optional<double> nees;
};

template <int D>
AgentError agent_error(const Eigen::Matrix<double, D, 1>& error,
                       const Eigen::Matrix<double, D, D>& covariance, bool valid) {
  AgentError result{error.norm(), valid && !covariance.allFinite(), std::nullopt};
  if (valid && covariance.allFinite() && covariance.determinant() > 0.0)
    result.nees = error.dot(covariance.ldlt().solve(error));
  return result;
}

}  // namespace

ErrorStats score(const std::vector<Vec2>& truth, const std::vector<bool>& is_anchor,
                 const std::vector<std::optional<estimators::Estimate>>& estimates,
                 const std::vector<double>* truth_z) {
  ErrorStats stats;
  double squared = 0.0;
  double sum = 0.0;
  double nees_sum = 0.0;
  int nees_count = 0;
  bool broken_mean = false;
  bool broken_nees = false;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    if (is_anchor[i]) continue;
    if (!estimates[i]) {
      ++stats.missing;
      continue;
    }
    if (!truth[i].allFinite()) {  // recorded data without ground truth at this instant: nothing to score
      ++stats.missing;
      continue;
    }
    const estimators::Estimate& estimate = *estimates[i];
    if (truth_z != nullptr && !estimate.altitude) {  // a planar estimate of a point in space: none
      ++stats.missing;
      continue;
    }
    const AgentError error =
        truth_z == nullptr
            ? agent_error<2>(estimate.mean_m - truth[i], estimate.covariance, estimate.valid)
            : agent_error<3>(join(estimate.mean_m, estimate.altitude->z_m) - join(truth[i], (*truth_z)[i]),
                             join(estimate.covariance, *estimate.altitude), estimate.valid);
    const double norm = error.norm;
    const bool broken_covariance = error.broken_covariance;
    if (!std::isfinite(norm) || broken_covariance) ++stats.non_finite;
    if (broken_covariance) broken_nees = true;
    if (!std::isfinite(norm)) {
      broken_mean = true;
      continue;
    }
    squared += norm * norm;
    sum += norm;
    stats.max_error_m = std::max(stats.max_error_m, norm);
    ++stats.scored;
    if (estimates[i]->inconsistent) ++stats.flagged;
    if (error.nees) {
      nees_sum += *error.nees;
      ++nees_count;
    }
  }
  if (stats.scored > 0) {
    stats.rmse_m = std::sqrt(squared / stats.scored);
    stats.mean_error_m = sum / stats.scored;
  }
  stats.nees = nees_count > 0 ? nees_sum / nees_count : std::numeric_limits<double>::quiet_NaN();
  stats.nees_agents = nees_count;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  if (broken_mean) stats.rmse_m = stats.mean_error_m = stats.max_error_m = kInf;
  if (broken_nees) stats.nees = kInf;
  return stats;
}

ErrorStats score(const World& world, const std::vector<std::optional<estimators::Estimate>>& estimates) {
  // Localization worlds score against the truth as it is (no per-step copies); a target world scores every
  // sensor against the target.
  const auto n = static_cast<std::size_t>(world.size());
  ErrorStats stats =
      world.estimates_target()
          ? score(std::vector<Vec2>(n, world.scored_truth(0)), std::vector<bool>(n, false), estimates)
          : score(world.truth, world.is_anchor, estimates, world.dimensions == 3 ? &world.altitude : nullptr);
  if (world.field.size() == 0) return stats;
  double squared = 0.0;
  bool broken_field = false;
  for (std::size_t i = 0; i < estimates.size(); ++i) {
    const auto& estimate = estimates[i];
    if (!estimate || estimate->field.size() != world.field.size()) continue;
    const double error = (estimate->field - world.field).squaredNorm();
    if (!std::isfinite(error)) {
      broken_field = true;
      // Once per agent: a non-anchor with a broken position is counted already.
      if (world.is_anchor[i] || !holds_non_finite(*estimate)) ++stats.non_finite;
      continue;
    }
    squared += error / static_cast<double>(world.field.size());
    ++stats.field_scored;
  }
  if (stats.field_scored > 0) stats.field_rmse = std::sqrt(squared / stats.field_scored);
  if (broken_field) stats.field_rmse = std::numeric_limits<double>::infinity();
  return stats;
}

std::optional<double> pose_nees(const models::Pose& estimate, const models::Mat3& covariance,
                                const models::Pose& truth) {
  models::Pose error;
  error << estimate.head<2>() - truth.head<2>(), models::wrap_angle(estimate.z() - truth.z());
  if (!error.allFinite() || !covariance.allFinite()) return std::nullopt;
  const Eigen::LLT<models::Mat3> llt(0.5 * (covariance + covariance.transpose()));
  if (llt.info() != Eigen::Success) return std::nullopt;
  return error.dot(llt.solve(error));
}

std::optional<double> pose_nees(const estimators::Estimate& estimate, const Vec2& truth_m,
                                double truth_heading_rad) {
  if (!estimate.valid || !estimate.heading) return std::nullopt;
  const auto& heading = *estimate.heading;
  models::Mat3 covariance;
  covariance.topLeftCorner<2, 2>() = estimate.covariance;
  covariance.block<2, 1>(0, 2) = heading.position_cov_m_rad;
  covariance.block<1, 2>(2, 0) = heading.position_cov_m_rad.transpose();
  covariance(2, 2) = heading.variance_rad2;
  const models::Pose estimated(estimate.mean_m.x(), estimate.mean_m.y(), heading.heading_rad);
  return pose_nees(estimated, covariance, models::Pose(truth_m.x(), truth_m.y(), truth_heading_rad));
}

double RangeCrlb::accumulated_rmse_m(double snapshots) const {
  if (!fresh_draws_per_step) return single_snapshot_rmse_m;
  return snapshots > 0.0 ? single_snapshot_rmse_m / std::sqrt(snapshots) : single_snapshot_rmse_m;
}

Mat2 target_information(const World& world, const config::Scenario& s, const Vec2& target) {
  Mat2 information = Mat2::Zero();
  const double range_variance = s.noise.target_std_m * s.noise.target_std_m;
  const double bearing_variance = s.noise.target_bearing_std_rad * s.noise.target_bearing_std_rad;
  for (const Vec2& sensor : world.truth) {
    if (s.world.target_sensing_radius_m > 0.0 && (target - sensor).norm() > s.world.target_sensing_radius_m)
      continue;
    if (s.world.target_sensing == config::TargetSensing::kLinear) {
      information += Mat2::Identity() / range_variance;
      continue;
    }
    const auto r = models::range(sensor, target);
    const auto b = models::bearing(sensor, target);
    if (!r || !b) continue;  // the sensor sits on the target: no reading (world.cpp)
    information +=
        r->d_xj.transpose() * r->d_xj / range_variance + b->d_xj.transpose() * b->d_xj / bearing_variance;
  }
  return information;
}

namespace {

/// The CRLB of a 3-D world's ranges (World::dimensions == 3): `observations` over the agents' (x, y, z),
/// anchors known, 3 coordinates per agent.
RangeCrlb spatial_range_crlb(const World& world, std::vector<estimators::RangeObservation> observations) {
  estimators::RangeNetwork3 network;
  network.truth.reserve(static_cast<std::size_t>(world.size()));
  for (AgentId i = 0; i < world.size(); ++i) network.truth.push_back(world.position3(i));
  network.is_anchor = world.is_anchor;
  network.ranges = std::move(observations);
  const auto result = estimators::network_crlb(network);
  RangeCrlb crlb;
  crlb.single_snapshot_rmse_m = result.network_rmse_m;
  crlb.per_agent_single_rmse_m = result.per_agent_rmse_m;
  crlb.localizable = result.localizable;
  return crlb;
}

}  // namespace

RangeCrlb range_crlb(const World& world, double range_std_m) {
  std::vector<estimators::RangeObservation> observations;
  for (int i = 0; i < world.size(); ++i) {
    for (AgentId j : world.neighbours[static_cast<std::size_t>(i)]) {
      observations.push_back({i, j, range_std_m});
    }
  }
  if (world.dimensions == 3) return spatial_range_crlb(world, std::move(observations));
  const auto result = estimators::range_network_crlb(world.truth, world.is_anchor, observations, 1.0);
  RangeCrlb crlb;
  crlb.single_snapshot_rmse_m = result.network_rmse_m;
  crlb.per_agent_single_rmse_m = result.per_agent_rmse_m;
  crlb.localizable = result.localizable;
  return crlb;
}

}  // namespace swarmloc::world

namespace swarmloc::world {
namespace {

constexpr int kMaxDenseCrlbAgents = 3000;  // dense L⁻¹ beyond this costs seconds and ~70 MB
/// The range bound's dense 2n x 2n Fisher inverse: ~1 s at this size, O(n³) beyond (docs/scale.md).
constexpr long kMaxDenseRangeCrlbAgents = 1000;

/// Each non-anchor agent's row in the bounds' matrices (−1 for anchors), and how many there are.
std::pair<std::vector<int>, int> index_unknowns(const World& world) {
  std::vector<int> unknown_index(static_cast<std::size_t>(world.size()), -1);
  int unknowns = 0;
  for (int i = 0; i < world.size(); ++i) {
    if (!world.is_anchor[static_cast<std::size_t>(i)])
      unknown_index[static_cast<std::size_t>(i)] = unknowns++;
  }
  return {std::move(unknown_index), unknowns};
}

RangeCrlb relative_crlb(const World& world, double relative_std_m) {
  RangeCrlb crlb;
  const auto [unknown_index, unknowns] = index_unknowns(world);
  if (unknowns == 0 || unknowns > kMaxDenseCrlbAgents) {
    crlb.single_snapshot_rmse_m = unknowns == 0 ? 0.0 : std::numeric_limits<double>::quiet_NaN();
    return crlb;
  }
  // Per axis: information = L_u / σ², L_u the graph Laplacian restricted to the unknowns (one shared
  // draw per link, so each link counts once).
  MatX laplacian = MatX::Zero(unknowns, unknowns);
  for (int i = 0; i < world.size(); ++i) {
    for (AgentId j : world.neighbours[static_cast<std::size_t>(i)]) {
      if (j <= i) continue;
      const int a = unknown_index[static_cast<std::size_t>(i)];
      const int b = unknown_index[static_cast<std::size_t>(j)];
      if (a >= 0) laplacian(a, a) += 1.0;
      if (b >= 0) laplacian(b, b) += 1.0;
      if (a >= 0 && b >= 0) laplacian(a, b) -= 1.0, laplacian(b, a) -= 1.0;
    }
  }
  const Eigen::LDLT<MatX> ldlt(laplacian);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 1e-12)) {
    crlb.localizable = false;
    crlb.single_snapshot_rmse_m = std::numeric_limits<double>::infinity();
    return crlb;
  }
  const MatX inverse = ldlt.solve(MatX::Identity(unknowns, unknowns));
  const double variance = relative_std_m * relative_std_m;
  double total = 0.0;
  crlb.per_agent_single_rmse_m.assign(static_cast<std::size_t>(world.size()), 0.0);
  for (int i = 0; i < world.size(); ++i) {
    const int a = unknown_index[static_cast<std::size_t>(i)];
    if (a < 0) continue;
    const double mse = 2.0 * variance * inverse(a, a);  // x and y
    crlb.per_agent_single_rmse_m[static_cast<std::size_t>(i)] = std::sqrt(mse);
    total += mse;
  }
  crlb.single_snapshot_rmse_m = std::sqrt(total / unknowns);
  return crlb;
}

/// The paths' bound (docs/algorithms.md §5.4): eq. (1)'s linear model with the noise-free angles, each
/// neighbour pair's reflections one shared draw of variance σ² (world.cpp add_paths), anchors known. It
/// takes the angles as exact, so angle errors (noise.doa_error_deg) are not in it.
RangeCrlb multipath_crlb(const World& world, const config::Scenario& s) {
  RangeCrlb crlb;
  const auto [unknown_index, unknowns] = index_unknowns(world);
  if (unknowns == 0 || unknowns > kMaxDenseRangeCrlbAgents) {
    crlb.single_snapshot_rmse_m = unknowns == 0 ? 0.0 : std::numeric_limits<double>::quiet_NaN();
    return crlb;
  }
  const double variance = s.noise.range_std_m * s.noise.range_std_m;
  MatX information = MatX::Zero(2 * unknowns, 2 * unknowns);
  for (int lo = 0; lo < world.size(); ++lo) {
    for (AgentId hi : world.neighbours[static_cast<std::size_t>(lo)]) {
      if (hi <= lo) continue;
      const Vec2& s_lo = world.truth[static_cast<std::size_t>(lo)];
      const Vec2& s_hi = world.truth[static_cast<std::size_t>(hi)];
      Mat2 block = Mat2::Zero();
      for (const auto& wall : world.walls) {
        const auto path = models::reflect_path(s_lo, s_hi, wall);
        if (!path) continue;
        const Vec2 g = models::path_direction(path->theta_ij_rad, path->theta_ji_rad);  // d = gᵀ(s_lo − s_hi)
        block += g * g.transpose() / variance;
      }
      const int a = unknown_index[static_cast<std::size_t>(lo)];
      const int b = unknown_index[static_cast<std::size_t>(hi)];
      if (a >= 0) information.block<2, 2>(2 * a, 2 * a) += block;
      if (b >= 0) information.block<2, 2>(2 * b, 2 * b) += block;
      if (a >= 0 && b >= 0) {
        information.block<2, 2>(2 * a, 2 * b) -= block;
        information.block<2, 2>(2 * b, 2 * a) -= block;
      }
    }
  }
  const Eigen::LDLT<MatX> ldlt(information);
  if (ldlt.info() != Eigen::Success ||
      !(ldlt.vectorD().minCoeff() > 1e-12 * information.diagonal().maxCoeff())) {
    crlb.localizable = false;
    crlb.single_snapshot_rmse_m = std::numeric_limits<double>::infinity();
    return crlb;
  }
  const MatX covariance = ldlt.solve(MatX::Identity(2 * unknowns, 2 * unknowns));
  double total = 0.0;
  crlb.per_agent_single_rmse_m.assign(static_cast<std::size_t>(world.size()), 0.0);
  for (int i = 0; i < world.size(); ++i) {
    const int a = unknown_index[static_cast<std::size_t>(i)];
    if (a < 0) continue;
    const double mse = covariance(2 * a, 2 * a) + covariance(2 * a + 1, 2 * a + 1);
    crlb.per_agent_single_rmse_m[static_cast<std::size_t>(i)] = std::sqrt(mse);
    total += mse;
  }
  crlb.single_snapshot_rmse_m = std::sqrt(total / unknowns);
  return crlb;
}

/// The static target's bound: J_1 = target_information at the true target (the centralized estimate's
/// information from one step of readings). Every sensor estimates the same target, so the per-sensor bound
/// is the network's.
RangeCrlb target_crlb(const World& world, const config::Scenario& s) {
  RangeCrlb crlb;
  if (s.world.target_motion != config::TargetMotion::kStatic) {
    crlb.single_snapshot_rmse_m = std::numeric_limits<double>::quiet_NaN();
    return crlb;
  }
  const Mat2 information = target_information(world, s, world.target.head<2>());
  const Eigen::LDLT<Mat2> ldlt(information);
  if (ldlt.info() != Eigen::Success || !(information.determinant() > 0.0)) {
    crlb.localizable = false;
    crlb.single_snapshot_rmse_m = std::numeric_limits<double>::infinity();
    return crlb;
  }
  crlb.single_snapshot_rmse_m = std::sqrt(information.inverse().trace());
  crlb.per_agent_single_rmse_m.assign(static_cast<std::size_t>(world.size()), crlb.single_snapshot_rmse_m);
  return crlb;
}

}  // namespace

RangeCrlb scenario_crlb(const World& world, const config::Scenario& scenario) {
  const MeasurementKinds kinds = measurement_kinds(scenario.algorithm.name);
  RangeCrlb crlb;
  const auto unknowns = std::count(world.is_anchor.begin(), world.is_anchor.end(), false);
  if (kinds.ranges && unknowns > kMaxDenseRangeCrlbAgents) {
    // The range bound inverts a dense 2n x 2n Fisher matrix (an eigendecomposition when it is
    // singular): at 10^4 agents that ran for over 10 minutes before the first step. Not computed.
    crlb.single_snapshot_rmse_m = std::numeric_limits<double>::quiet_NaN();
    return crlb;
  }
  if (world.dimensions == 3 && (!kinds.ranges || kinds.targets || kinds.relative || kinds.paths)) {
    // A 3-D world's bound is that of its ranges (docs/algorithms.md §1.3): the others are planar.
    crlb.single_snapshot_rmse_m = std::numeric_limits<double>::quiet_NaN();
  } else if (world.dimensions == 3 && scenario.noise.range_model != config::RangeNoise::kAdditive) {
    std::vector<estimators::RangeObservation> observations;
    for (int i = 0; i < world.size(); ++i) {
      for (AgentId j : world.neighbours[static_cast<std::size_t>(i)])
        observations.push_back({i, j, std::max(1e-9, scenario.noise.range_std_at(world.distance(i, j)))});
    }
    crlb = spatial_range_crlb(world, std::move(observations));
  } else if (kinds.targets) {
    crlb = target_crlb(world, scenario);
  } else if (kinds.relative) {
    crlb = relative_crlb(world, scenario.noise.relative_std_m);
  } else if (kinds.paths) {
    crlb = multipath_crlb(world, scenario);
  } else if (kinds.ranges && scenario.noise.range_model != config::RangeNoise::kAdditive) {
    std::vector<estimators::RangeObservation> observations;
    for (int i = 0; i < world.size(); ++i) {
      for (AgentId j : world.neighbours[static_cast<std::size_t>(i)]) {
        const double distance =
            (world.truth[static_cast<std::size_t>(i)] - world.truth[static_cast<std::size_t>(j)]).norm();
        observations.push_back({i, j, std::max(1e-9, scenario.noise.range_std_at(distance))});
      }
    }
    const auto result = estimators::range_network_crlb(world.truth, world.is_anchor, observations, 1.0);
    crlb.single_snapshot_rmse_m = result.network_rmse_m;
    crlb.per_agent_single_rmse_m = result.per_agent_rmse_m;
    crlb.localizable = result.localizable;
  } else if (kinds.ranges) {
    crlb = range_crlb(world, scenario.noise.range_std_m);
  } else {
    crlb.single_snapshot_rmse_m = std::numeric_limits<double>::quiet_NaN();
  }
  // Shared draws: both ends hold the same value, which counts once; per-endpoint draws count twice
  // (range_crlb's observation list already holds each link from both ends).
  if (kinds.ranges && scenario.noise.shared_range_draws) {
    crlb.single_snapshot_rmse_m *= std::sqrt(2.0);
    for (double& rmse : crlb.per_agent_single_rmse_m) rmse *= std::sqrt(2.0);
  }
  crlb.fresh_draws_per_step = scenario.noise.draw == config::NoiseDraw::kPerStep;
  return crlb;
}

}  // namespace swarmloc::world
