#include "swarmloc/research/multipath_localization.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <random>
#include <stdexcept>

#include "swarmloc/estimators/bp/multipath_bp.hpp"
#include "swarmloc/models/multipath.hpp"
#include "sync_bus.hpp"

namespace swarmloc::research {
namespace {

constexpr int kNodes = 5;
constexpr std::array<std::array<int, 2>, 5> kLinks{{{1, 0}, {2, 0}, {3, 1}, {4, 2}, {3, 4}}};
constexpr std::array<int, 5> kPairwiseParent{-1, 0, 0, 1, 2};

}  // namespace

double abs_quantile(std::vector<double> values, double q) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  for (double& v : values) v = std::abs(v);
  std::sort(values.begin(), values.end());
  const double pos = std::clamp(q, 0.0, 1.0) * static_cast<double>(values.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (pos - static_cast<double>(lo)) * (values[hi] - values[lo]);
}

namespace {

using Positions = std::array<Vec2, kNodes>;

/// Walls outside the square, both endpoints of every pair on the same side (docs/algorithms.md §5.4 [D-6]).
std::vector<models::Wall> make_walls(const MultipathExperimentConfig& c) {
  const Vec2 center(0.5 * c.side_m, 0.5 * c.side_m);
  const double offset = c.side_m * std::numbers::sqrt2 / 2.0 + c.wall_margin_m;
  std::vector<models::Wall> walls;
  for (const double angle_deg : c.wall_angles_deg) {
    const double angle = angle_deg * std::numbers::pi / 180.0;
    const Vec2 normal(-std::sin(angle), std::cos(angle));
    walls.push_back(models::Wall{center - offset * normal, angle});
  }
  return walls;
}

/// The draws of one experiment, in the order they are made.
struct MultipathDraws {
  std::mt19937_64 rng;
  std::uniform_real_distribution<double> position;
  std::normal_distribution<double> range_noise;
  std::uniform_real_distribution<double> doa_noise;

  /// S_0 at the origin, the others uniform in the square.
  Positions positions() {
    Positions s;
    s[0] = Vec2::Zero();
    for (int i = 1; i < kNodes; ++i) {
      const double x = position(rng);
      s[static_cast<std::size_t>(i)] = Vec2(x, position(rng));
    }
    return s;
  }
};

/// Every node's measured paths: one reflection per wall and link.
std::vector<estimators::MeasurementBatch> measure_paths(const MultipathExperimentConfig& c,
                                                        const std::vector<models::Wall>& walls,
                                                        const Positions& s, MultipathDraws& draws) {
  std::vector<estimators::MeasurementBatch> batches(kNodes);
  for (const auto& link : kLinks) {
    const int i = link[0];
    const int j = link[1];
    for (std::size_t r = 0; r < walls.size(); ++r) {
      const auto path =
          models::reflect_path(s[static_cast<std::size_t>(i)], s[static_cast<std::size_t>(j)], walls[r]);
      if (!path) throw std::logic_error("multipath_experiment: wall between two nodes");
      // One noisy path shared by both ends; DOA errors independent at each end (docs/algorithms.md §5.4).
      const double length_error = draws.range_noise(draws.rng);
      const double theta_ji = path->theta_ji_rad + draws.doa_noise(draws.rng);
      const double theta_ij = path->theta_ij_rad + draws.doa_noise(draws.rng);
      const double length =
          length_error + (c.lengths_from_measured_angles
                              ? models::path_direction(theta_ij, theta_ji)
                                    .dot(s[static_cast<std::size_t>(i)] - s[static_cast<std::size_t>(j)])
                              : path->length_m);
      const int index = static_cast<int>(r);
      batches[static_cast<std::size_t>(i)].paths.push_back({j, index, length, theta_ji, theta_ij});
      batches[static_cast<std::size_t>(j)].paths.push_back({i, index, length, theta_ij, theta_ji});
    }
  }
  return batches;
}

/// One trial of cooperative BP (Leng et al. Algorithm 1).
struct BpTrial {
  bool grew = false;                ///< some belief's covariance grew between iterations (Thm. 1)
  bool localized = true;            ///< every node has a belief at the end
  std::vector<double> abs_x_error;  ///< per iteration, summed over S1–S4
  Positions means;
};

BpTrial run_bp_trial(const detail::Adjacency& adjacency, const estimators::bp::MultipathBpParams& params,
                     const std::vector<estimators::MeasurementBatch>& batches, const Positions& s,
                     std::size_t iterations) {
  std::vector<std::unique_ptr<estimators::Estimator>> agents;
  std::vector<const estimators::bp::MultipathBp*> bp;
  for (int i = 0; i < kNodes; ++i) {
    estimators::AgentSetup setup;
    setup.id = i;
    setup.anchor = i == 0;
    auto agent = std::make_unique<estimators::bp::MultipathBp>(setup, params);
    bp.push_back(agent.get());
    agents.push_back(std::move(agent));
  }
  detail::SyncBus bus(adjacency);
  bus.publish_initial(agents);
  std::vector<const estimators::MeasurementBatch*> first;
  first.reserve(batches.size());
  for (const auto& b : batches) first.push_back(&b);
  const std::vector<const estimators::MeasurementBatch*> none(kNodes, nullptr);
  std::array<Mat2, kNodes> previous_info;
  previous_info.fill(Mat2::Zero());
  BpTrial trial;
  trial.abs_x_error.assign(iterations + 1, 0.0);
  for (std::size_t l = 1; l <= iterations; ++l) {
    bus.round(agents, static_cast<std::int64_t>(l), l == 1 ? first : none);
    for (int i = 1; i < kNodes; ++i) {
      const auto k = static_cast<std::size_t>(i);
      const Mat2 info = bp[k]->information();
      const Mat2 gain = info - previous_info[k];  // Thm. 1: Λ non-decreasing ⇔ P non-increasing
      const double min_eig =
          Eigen::SelfAdjointEigenSolver<Mat2>(0.5 * (gain + gain.transpose())).eigenvalues()(0);
      if (min_eig < -1e-9 * std::max(1.0, info.norm())) trial.grew = true;
      previous_info[k] = info;
      trial.abs_x_error[l] += std::abs(bp[k]->mean().x() - s[k].x());
    }
  }
  for (int i = 1; i < kNodes; ++i)
    trial.localized = trial.localized && bp[static_cast<std::size_t>(i)]->localized();
  for (std::size_t k = 0; k < kNodes; ++k) trial.means[k] = bp[k]->mean();
  return trial;
}

/// Centralized baseline (not in Leng et al.): every link's paths in one weighted least-squares problem.
void add_centralized(MultipathExperimentResult& result,
                     const std::vector<estimators::MeasurementBatch>& batches, const Positions& s,
                     const estimators::bp::MultipathBpParams& params) {
  std::vector<std::optional<Vec2>> anchor_positions(kNodes);
  anchor_positions[0] = s[0];
  std::vector<estimators::bp::LinkPaths> links;
  links.reserve(kLinks.size());
  for (const auto& link : kLinks) {
    links.push_back({link[0], link[1],
                     estimators::bp::path_set(batches[static_cast<std::size_t>(link[0])].paths, link[1])});
  }
  if (const auto central = estimators::bp::centralized_from_paths(anchor_positions, links, params)) {
    for (int i = 1; i < kNodes; ++i) {
      const auto k = static_cast<std::size_t>(i);
      result.centralized_x_error[k].push_back((*central)[k].mean.x() - s[k].x());
      result.centralized_y_error[k].push_back((*central)[k].mean.y() - s[k].y());
    }
  }
}

/// Pairwise baseline (docs/algorithms.md §5.4): S_1, S_2 from S_0; S_3 from S_1; S_4 from S_2.
void add_pairwise(MultipathExperimentResult& result, const std::vector<estimators::MeasurementBatch>& batches,
                  const Positions& s, const estimators::bp::MultipathBpParams& params) {
  std::array<estimators::bp::Gaussian2, kNodes> pairwise;
  pairwise[0] = estimators::bp::Gaussian2{Vec2::Zero(), Mat2::Zero()};
  for (int i = 1; i < kNodes; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const int parent = kPairwiseParent[k];
    const auto paths = estimators::bp::path_set(batches[k].paths, parent);
    const auto child =
        estimators::bp::pairwise_from_parent(pairwise[static_cast<std::size_t>(parent)], paths, params);
    if (!child) return;
    pairwise[k] = *child;
  }
  for (int i = 1; i < kNodes; ++i) {
    const auto k = static_cast<std::size_t>(i);
    result.pairwise_x_error[k].push_back(pairwise[k].mean.x() - s[k].x());
    result.pairwise_y_error[k].push_back(pairwise[k].mean.y() - s[k].y());
  }
}

}  // namespace

MultipathExperimentResult run_multipath_experiment(const MultipathExperimentConfig& c) {
  if (c.trials < 1 || c.iterations < 1 || c.wall_angles_deg.empty()) {
    throw std::invalid_argument("multipath_experiment: trials, iterations and walls must be >= 1");
  }
  const double doa = c.doa_error_deg * std::numbers::pi / 180.0;
  MultipathDraws draws{std::mt19937_64(c.seed), std::uniform_real_distribution<double>(0.0, c.side_m),
                       std::normal_distribution<double>(0.0, c.range_std_m),
                       std::uniform_real_distribution<double>(-doa, doa)};
  const double sigma2 = c.algorithm_sigma2 > 0.0 ? c.algorithm_sigma2 : c.range_std_m * c.range_std_m;
  estimators::bp::MultipathBpParams params;
  params.sigma2 = sigma2;
  if (c.doa_aware_paths) params.doa_variance_rad2 = doa * doa / 3.0;
  params.exact_messages = c.exact_messages;
  const auto walls = make_walls(c);
  detail::Adjacency adjacency(kNodes);
  for (const auto& link : kLinks) {
    adjacency[static_cast<std::size_t>(link[0])].push_back(link[1]);
    adjacency[static_cast<std::size_t>(link[1])].push_back(link[0]);
  }

  MultipathExperimentResult result;
  for (auto* v : {&result.bp_x_error, &result.bp_y_error, &result.pairwise_x_error, &result.pairwise_y_error,
                  &result.centralized_x_error, &result.centralized_y_error}) {
    v->assign(kNodes, {});
  }
  const auto iterations = static_cast<std::size_t>(c.iterations);
  std::vector<double> abs_sum(iterations + 1, 0.0);
  double abs_count = 0.0;
  for (int trial = 0; trial < c.trials; ++trial) {
    const auto s = draws.positions();
    const auto batches = measure_paths(c, walls, s, draws);
    const auto bp = run_bp_trial(adjacency, params, batches, s, iterations);
    if (bp.grew) ++result.covariance_increase_trials;
    if (!bp.localized) {
      ++result.trials_unlocalized;
      continue;
    }
    for (std::size_t l = 1; l <= iterations; ++l) abs_sum[l] += bp.abs_x_error[l];
    abs_count += kNodes - 1;
    for (int i = 1; i < kNodes; ++i) {
      const auto k = static_cast<std::size_t>(i);
      result.bp_x_error[k].push_back(bp.means[k].x() - s[k].x());
      result.bp_y_error[k].push_back(bp.means[k].y() - s[k].y());
    }
    add_centralized(result, batches, s, params);
    add_pairwise(result, batches, s, params);
  }
  result.bp_mean_abs_x_error.assign(iterations + 1, std::numeric_limits<double>::quiet_NaN());
  if (abs_count > 0.0) {
    for (std::size_t l = 1; l <= iterations; ++l) result.bp_mean_abs_x_error[l] = abs_sum[l] / abs_count;
  }
  return result;
}

}  // namespace swarmloc::research
