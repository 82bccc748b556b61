#include "swarmloc/research/centralized_experiments.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "swarmloc/core/random.hpp"
#include "swarmloc/estimators/centralized/posterior_crb.hpp"

namespace swarmloc::research {

MatX make_ea1_matrix(int n, int bandwidth_of_a, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> off_diagonal(-1.0, 1.0);
  MatX a = MatX::Zero(n, n);
  for (int j = 0; j < n; ++j) {
    a(j, j) = 15.0;
    for (int i = j + 1; i <= std::min(n - 1, j + bandwidth_of_a); ++i) {
      a(i, j) = off_diagonal(rng);
      a(j, i) = a(i, j);
    }
  }
  return a / a.cwiseAbs().maxCoeff();  // "normalized" ([E-A1]: by the largest absolute entry)
}

std::vector<double> banded_inversion_errors(int n, int bandwidth_of_a, const std::vector<int>& bandwidths,
                                            std::mt19937_64& rng, centralized::BandInversionMethod method) {
  const MatX a = make_ea1_matrix(n, bandwidth_of_a, rng);
  Eigen::LLT<MatX> llt(a);
  if (llt.info() != Eigen::Success) throw std::domain_error("E-A1: matrix is not positive definite");
  const MatX exact = llt.solve(MatX::Identity(n, n));
  std::vector<double> errors;
  errors.reserve(bandwidths.size());
  for (int bandwidth : bandwidths)
    errors.push_back((exact - centralized::band_inverse(a, bandwidth, method)).norm());
  return errors;
}

double banded_inversion_error(int n, int bandwidth_of_a, int bandwidth, std::mt19937_64& rng,
                              centralized::BandInversionMethod method) {
  return banded_inversion_errors(n, bandwidth_of_a, {bandwidth}, rng, method).front();
}

// eq. (33): the best window [a, a + r] can be slid right until its left edge meets a point.
int max_strip_count(const std::vector<double>& sorted_x, double strip_width) {
  int best = 0;
  std::size_t right = 0;
  for (std::size_t left = 0; left < sorted_x.size(); ++left) {
    right = std::max(right, left);
    while (right < sorted_x.size() && sorted_x[right] <= sorted_x[left] + strip_width) ++right;
    best = std::max(best, static_cast<int>(right - left));
  }
  return best;
}

VrBoundSample vr_bandwidth_bound(double lambda, double side_m, double radius_m, std::mt19937_64& rng) {
  std::poisson_distribution<int> count(lambda * side_m * side_m);
  std::uniform_real_distribution<double> coordinate(0.0, side_m);
  VrBoundSample sample;
  sample.num_agents = count(rng);
  std::vector<double> x(static_cast<std::size_t>(sample.num_agents));
  for (double& xi : x) xi = coordinate(rng);
  std::sort(x.begin(), x.end());
  sample.phi_max = max_strip_count(x, radius_m);
  return sample;
}

Ea2World make_ea2_world(const Ea2Config& config) {
  if (config.num_beacons > config.num_agents || config.num_agents < 2) {
    throw std::invalid_argument("E-A2: num_beacons " + std::to_string(config.num_beacons) +
                                " is outside [0, " + std::to_string(config.num_agents) + "]");
  }
  std::uniform_real_distribution<double> coordinate(0.0, config.domain_m);
  for (int attempt = 0; attempt < config.max_attempts; ++attempt) {
    auto placement = core::make_engine(config.config_seed, core::Stream::kPlacement, attempt);
    Ea2World world;
    world.positions.resize(static_cast<std::size_t>(config.num_agents));
    for (Vec2& p : world.positions) {
      p.x() = coordinate(placement);
      p.y() = coordinate(placement);
    }
    world.edges = centralized::disk_graph_edges(world.positions, config.sensing_radius_m);
    world.vr_bandwidth =
        centralized::graph_bandwidth(world.edges, centralized::lexicographic_labels(world.positions));
    if (config.max_vr_bandwidth >= 0 && world.vr_bandwidth > config.max_vr_bandwidth) continue;
    if (!centralized::is_connected(config.num_agents, world.edges) ||
        !centralized::is_rigid(world.positions, world.edges))
      continue;
    auto anchors = core::make_engine(config.config_seed, core::Stream::kAnchors, attempt);
    std::vector<int> agents = centralized::identity_labels(config.num_agents);
    std::shuffle(agents.begin(), agents.end(), anchors);
    world.beacons.assign(agents.begin(), agents.begin() + config.num_beacons);
    std::sort(world.beacons.begin(), world.beacons.end());
    world.natural_bandwidth =
        centralized::graph_bandwidth(world.edges, centralized::identity_labels(config.num_agents));
    world.attempts = attempt + 1;
    return world;
  }
  throw std::runtime_error("E-A2: no connected, rigid configuration with the bandwidth limit in " +
                           std::to_string(config.max_attempts) + " attempts");
}

namespace {

Eigen::Index ea2_index(int a) { return 2 * static_cast<Eigen::Index>(a); }

// The filter of `variant`; its labels are Khan et al. Alg. 3's relabeling once at k = 0 ([A-5]) where the
// variant relabels, else the generation order.
centralized::CentralizedKind ea2_filter_params(const Ea2Config& config, const Ea2World& world,
                                               Ea2Variant variant, const VecX& initial_mean,
                                               centralized::CentralizedFilterParams& params) {
  const int agents = config.num_agents;
  params.process_var = config.process_var;
  params.inversion = config.inversion;
  centralized::CentralizedKind kind = centralized::CentralizedKind::kEkf;
  bool relabel = false;
  switch (variant) {
    case Ea2Variant::kEkf:
      params.bandwidth = 2 * agents - 1;
      break;
    case Ea2Variant::kLbEkfVr:
      kind = centralized::CentralizedKind::kLbEkf;
      relabel = true;
      break;
    case Ea2Variant::kLbEkfNoVr:
      kind = centralized::CentralizedKind::kLbEkf;
      break;
    case Ea2Variant::kLbEkfIVr:
      kind = centralized::CentralizedKind::kLbEkfI;
      relabel = true;
      break;
    case Ea2Variant::kLbEkfINoVr:
      kind = centralized::CentralizedKind::kLbEkfI;
      break;
  }
  if (kind != centralized::CentralizedKind::kEkf) params.bandwidth = config.bandwidth;
  if (relabel) {
    std::vector<Vec2> reference(static_cast<std::size_t>(agents));
    for (int a = 0; a < agents; ++a) {
      reference[static_cast<std::size_t>(a)] = config.relabel_from_truth
                                                   ? world.positions[static_cast<std::size_t>(a)]
                                                   : Vec2(initial_mean.segment<2>(ea2_index(a)));
    }
    params.labels = centralized::lexicographic_labels(reference);
  } else {
    params.labels = centralized::identity_labels(agents);  // generation order
  }
  return kind;
}

// eq. (5) at the true `positions`; the disk graph follows them (docs/algorithms.md §1.2).
centralized::CentralizedMeasurements ea2_measurements(const Ea2Config& config, const Ea2World& world,
                                                      const std::vector<Vec2>& positions,
                                                      std::mt19937_64& noise_rng,
                                                      std::normal_distribution<double>& standard) {
  const double beacon_std = std::sqrt(config.beacon_var);
  const double range_std = std::sqrt(config.range_var);
  centralized::CentralizedMeasurements meas;
  meas.beacon_var = config.beacon_var;
  meas.range_var = config.range_var;
  for (int b : world.beacons) {
    const Vec2 noise = beacon_std * Vec2(standard(noise_rng), standard(noise_rng));
    meas.beacon_fixes.emplace_back(b, positions[static_cast<std::size_t>(b)] + noise);
  }
  for (const auto& [i, j] : centralized::disk_graph_edges(positions, config.sensing_radius_m)) {
    const double range =
        (positions[static_cast<std::size_t>(i)] - positions[static_cast<std::size_t>(j)]).norm();
    meas.ranges.push_back({i, j, range + range_std * standard(noise_rng)});
  }
  return meas;
}

}  // namespace

Ea2TrialResult run_ea2_trial(const Ea2Config& config, const Ea2World& world, Ea2Variant variant,
                             std::uint64_t trial_seed) {
  const int agents = config.num_agents;
  auto init_rng = core::make_engine(trial_seed, core::Stream::kInitialGuess);
  auto motion_rng = core::make_engine(trial_seed, core::Stream::kMotion);
  auto noise_rng = core::make_engine(trial_seed, core::Stream::kMeasurementNoise);
  std::normal_distribution<double> standard(0.0, 1.0);

  VecX truth(2 * agents);
  for (int a = 0; a < agents; ++a)
    truth.segment<2>(ea2_index(a)) = world.positions[static_cast<std::size_t>(a)];
  VecX initial_mean = truth;
  const double initial_std = std::sqrt(config.initial_var);
  for (Eigen::Index i = 0; i < initial_mean.size(); ++i) initial_mean(i) += initial_std * standard(init_rng);
  const std::vector<Mat2> initial_cov(static_cast<std::size_t>(agents),
                                      Mat2::Identity() * config.initial_var);

  centralized::CentralizedFilterParams params;
  const centralized::CentralizedKind kind = ea2_filter_params(config, world, variant, initial_mean, params);
  const auto filter = centralized::make_centralized_filter(kind, initial_mean, initial_cov, params);
  centralized::PosteriorCrb crb(initial_cov, config.process_var);

  Ea2TrialResult result;
  result.labels_bandwidth = centralized::graph_bandwidth(world.edges, params.labels);
  result.total_mse.assign(static_cast<std::size_t>(config.steps), 0.0);
  result.agent_mse = MatX::Zero(config.steps, agents);
  if (config.compute_crb) {
    result.crb_total.assign(static_cast<std::size_t>(config.steps), 0.0);
    result.crb_agent = MatX::Zero(config.steps, agents);
  }
  const double process_std = std::sqrt(config.process_var);
  std::vector<Vec2> positions = world.positions;
  for (int k = 0; k < config.steps; ++k) {
    if (k > 0) {  // eq. (4) with v = 0 ([A-6])
      for (Vec2& p : positions) p += process_std * Vec2(standard(motion_rng), standard(motion_rng));
      for (int a = 0; a < agents; ++a)
        truth.segment<2>(ea2_index(a)) = positions[static_cast<std::size_t>(a)];
    }
    const centralized::CentralizedMeasurements meas =
        ea2_measurements(config, world, positions, noise_rng, standard);
    filter->step(meas);
    result.max_measurement_bandwidth =
        std::max(result.max_measurement_bandwidth, filter->last_measurement_bandwidth());
    if (filter->last_truncated_entries() > 0) ++result.truncated_steps;
    const VecX error = filter->mean() - truth;
    for (int a = 0; a < agents; ++a) {
      const double e2 = error.segment<2>(ea2_index(a)).squaredNorm();
      result.agent_mse(k, a) = e2;
      result.total_mse[static_cast<std::size_t>(k)] += e2;
    }
    if (config.compute_crb) {
      crb.step(meas, truth);
      result.crb_total[static_cast<std::size_t>(k)] = crb.total_bound();
      for (int a = 0; a < agents; ++a) result.crb_agent(k, a) = crb.agent_bound(a).trace();
    }
  }
  return result;
}

Ea2TrialResult run_ea2_trial(const Ea2Config& config, Ea2Variant variant, std::uint64_t trial_seed) {
  return run_ea2_trial(config, make_ea2_world(config), variant, trial_seed);
}

}  // namespace swarmloc::research
