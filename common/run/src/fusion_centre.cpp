#include "swarmloc/run/fusion_centre.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/core/altitude.hpp"
#include "swarmloc/estimators/builders.hpp"
#include "swarmloc/estimators/centralized/relabeling.hpp"

namespace swarmloc::run {
namespace {

namespace centralized = estimators::centralized;

constexpr double kMinVariance = 1e-6;  // m²: exactly known anchors / noiseless ranges stay finite

}  // namespace

std::unique_ptr<centralized::CentralizedFilter> make_fusion_filter(const config::Scenario& scenario,
                                                                   const world::World& world) {
  const std::string& algorithm = scenario.algorithm.name;
  const config::AlgorithmSpec* spec = config::find_algorithm(algorithm);
  const estimators::EstimatorBuilder* builder = spec != nullptr ? &spec->build : nullptr;
  if (!config::runs_in_fusion_centre(algorithm) || builder == nullptr || !builder->fusion) {
    throw std::invalid_argument("make_fusion_filter: algorithm '" + algorithm + "' is not centralized");
  }
  const int n = world.size();
  const double initial_var =
      scenario.algorithm.kalman.initial_std_m * scenario.algorithm.kalman.initial_std_m;

  centralized::CentralizedFilterParams params;
  params.process_var =
      scenario.algorithm.kalman.process_noise_std_m * scenario.algorithm.kalman.process_noise_std_m;
  params.bandwidth = centralized_bandwidth(world.dimensions);
  // Khan et al. Alg. 3 with: the relabelling variants relabel once, from the best positions at
  // start-up.
  params.labels = builder->relabel ? centralized::lexicographic_labels(world.initial_guess)
                                   : centralized::identity_labels(n);
  // A static generated world ranges every pair within the radius at every step (world generate_batch);
  // a moving one only its step-0 pairs, so there a pair never ranged may well be within it.
  const bool disk_graph = scenario.world.source == config::WorldSource::kGenerated &&
                          scenario.world.motion == config::Motion::kStatic;
  if (disk_graph) params.disk_radius_m = scenario.world.comm_radius_m;
  if (world.dimensions == 3) {
    VecX initial_mean(3 * n);
    for (int i = 0; i < n; ++i) {
      const auto k = static_cast<std::size_t>(i);
      initial_mean.segment<3>(3 * i) = join(world.initial_guess[k], world.initial_altitude[k]);
    }
    const std::vector<Mat3> initial_cov(static_cast<std::size_t>(n), Mat3::Identity() * initial_var);
    return centralized::make_centralized_filter_3d(*builder->fusion, initial_mean, initial_cov, params);
  }
  VecX initial_mean(2 * n);
  for (int i = 0; i < n; ++i)
    initial_mean.segment<2>(2 * i) = world.initial_guess[static_cast<std::size_t>(i)];
  const std::vector<Mat2> initial_cov(static_cast<std::size_t>(n), Mat2::Identity() * initial_var);
  return centralized::make_centralized_filter(*builder->fusion, initial_mean, initial_cov, params);
}

centralized::CentralizedMeasurements centralized_measurements(
    const config::Scenario& scenario, const std::vector<const estimators::MeasurementBatch*>& batches) {
  centralized::CentralizedMeasurements out;
  out.beacon_var = std::max(kMinVariance, scenario.noise.anchor_fix_std_m * scenario.noise.anchor_fix_std_m);
  out.range_var = std::max(kMinVariance, scenario.noise.range_std_m * scenario.noise.range_std_m);
  const int n = static_cast<int>(batches.size());
  const bool spatial = scenario.world.dimensions == 3;
  for (int i = 0; i < n; ++i) {
    const auto* batch = batches[static_cast<std::size_t>(i)];
    if (batch == nullptr) continue;
    // In 3-D a fix is used with its z only; one without it fixes nothing the filter can use.
    if (batch->fix && (!spatial || batch->fix->z_m)) {
      out.beacon_fixes.emplace_back(i, batch->fix->position_m);
      if (spatial) out.beacon_fix_z.push_back(*batch->fix->z_m);
    }
    for (const auto& range : batch->ranges) {
      const int j = range.peer;
      if (j < 0 || j >= n || j == i) continue;
      // One range per undirected edge: the lower endpoint's, or the higher one's if the lower is missing.
      const bool lower = i < j;
      if (lower || batches[static_cast<std::size_t>(j)] == nullptr) {
        out.ranges.push_back({std::min(i, j), std::max(i, j), range.range_m});
      }
    }
  }
  return out;
}

estimators::Estimate fusion_estimate(const centralized::CentralizedFilter& filter, AgentId agent) {
  estimators::Estimate estimate;
  if (filter.dimension() == 3) {
    const Vec3 mean = filter.agent_mean_full(agent);
    const Mat3 covariance = filter.covariance_block_full(agent);
    estimate.mean_m = mean.head<2>();
    estimate.covariance = covariance.topLeftCorner<2, 2>();
    estimate.altitude = altitude_of(mean, covariance);
    estimate.valid = mean.allFinite() && covariance.allFinite();
  } else {
    estimate.mean_m = filter.agent_mean(agent);
    estimate.covariance = filter.covariance_block(agent);
    estimate.valid = estimate.mean_m.allFinite() && estimate.covariance.allFinite();
  }
  estimate.inconsistent = filter.inconsistent(agent);
  return estimate;
}

double total_squared_error(const std::vector<Vec2>& truth,
                           const std::vector<std::optional<estimators::Estimate>>& estimates,
                           const std::vector<double>& truth_z) {
  double total = 0.0;
  for (std::size_t i = 0; i < truth.size() && i < estimates.size(); ++i) {
    if (!estimates[i]) continue;
    total += (estimates[i]->mean_m - truth[i]).squaredNorm();
    if (i < truth_z.size() && estimates[i]->altitude)
      total += std::pow(estimates[i]->altitude->z_m - truth_z[i], 2);
  }
  return total;
}

}  // namespace swarmloc::run
