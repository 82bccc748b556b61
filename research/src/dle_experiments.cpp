// The DLE experiments of Atanasov et al. (docs/algorithms.md §4.6): a static target seen through random
// projections, and moving targets tracked from range and bearing against a centralized EKF.
#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <random>
#include <stdexcept>

#include "experiment_graphs.hpp"
#include "swarmloc/estimators/consensus/dle.hpp"
#include "swarmloc/models/measurement_models.hpp"
#include "swarmloc/research/relative_localization.hpp"
#include "sync_bus.hpp"

namespace swarmloc::research {
namespace {

using detail::Graph;
using detail::make_graph;
using detail::uniform_points;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Per-step sums over the runs of the static DLE experiment.
struct StaticDleSums {
  std::vector<double> se, counted, central_se, central_crb;
};

/// One run of the static DLE experiment: a connected graph, a target, and c.steps steps.
void run_static_dle_once(const StaticDleExperimentConfig& c, std::mt19937_64& rng,
                         std::normal_distribution<double>& normal, StaticDleSums& sums) {
  const auto steps = static_cast<std::size_t>(c.steps);
  const Eigen::Index d = c.target_dim;
  const double var = c.observation_std * c.observation_std;
  Graph g;
  for (int attempt = 0;; ++attempt) {
    if (attempt > 10000) throw std::runtime_error("static_dle_experiment: no connected graph");
    g = make_graph(uniform_points(c.num_nodes, c.side_m, rng), c.radius_m);
    if (detail::connected(g.adjacency)) break;
  }
  VecX y(d);
  for (Eigen::Index k = 0; k < d; ++k) y(k) = c.target_std * normal(rng);
  std::vector<std::unique_ptr<estimators::Estimator>> agents;
  std::vector<const estimators::consensus::Dle*> dle;
  std::vector<MatX> H;
  MatX M_total = MatX::Zero(d, d);
  for (int i = 0; i < c.num_nodes; ++i) {
    MatX Hi(2, d);
    for (Eigen::Index r = 0; r < 2; ++r) {
      for (Eigen::Index k = 0; k < d; ++k) Hi(r, k) = normal(rng);
    }
    H.push_back(Hi);
    M_total += Hi.transpose() * Hi / var;
    estimators::consensus::DleParams params;
    params.target_dim = c.target_dim;
    params.H = Hi;
    estimators::AgentSetup setup;
    setup.id = i;
    setup.initial_guess_m = g.positions[static_cast<std::size_t>(i)];
    auto agent = std::make_unique<estimators::consensus::Dle>(setup, params);
    dle.push_back(agent.get());
    agents.push_back(std::move(agent));
  }
  detail::SyncBus bus(g.adjacency);
  bus.publish_initial(agents);
  std::vector<estimators::MeasurementBatch> batches(static_cast<std::size_t>(c.num_nodes));
  std::vector<const estimators::MeasurementBatch*> batch_ptrs;
  for (std::size_t i = 0; i < batches.size(); ++i) {
    for (const int j : g.adjacency[i]) batches[i].neighbours.push_back(j);
    batch_ptrs.push_back(&batches[i]);
  }
  VecX central_info = VecX::Zero(d);
  const MatX M_inverse = M_total.inverse();
  for (std::size_t t = 1; t <= steps; ++t) {
    for (std::size_t i = 0; i < batches.size(); ++i) {
      const Vec2 noise(c.observation_std * normal(rng), c.observation_std * normal(rng));
      const Vec2 z = H[i] * y + noise;  // Atanasov et al. eq. (2)
      batches[i].targets = {estimators::TargetObservation{0, z, var * Mat2::Identity(), 0}};
      batches[i].world_step = static_cast<std::int64_t>(t);
      central_info += H[i].transpose() * z / var;
    }
    bus.round(agents, static_cast<std::int64_t>(t), batch_ptrs);
    for (const auto* node : dle) {
      if (!node->has_target_estimate()) continue;
      sums.se[t] += (node->target_estimate() - y).squaredNorm();
      sums.counted[t] += 1.0;
    }
    const double tt = static_cast<double>(t);
    sums.central_se[t] += (M_inverse * central_info / tt - y).squaredNorm();
    sums.central_crb[t] += M_inverse.trace() / tt;
  }
}

/// Per-step squared errors of the tracking experiment, summed over runs and targets.
struct TrackingSums {
  std::vector<double> node0_pos, others_pos, central_pos, node0_vel, others_vel, central_vel;
};

/// The target's constant-velocity model: F, W = q·(continuous white-acceleration noise), and W's factor.
struct TrackingModel {
  MatX F;
  MatX W;
  Eigen::LLT<MatX> W_root;
};

TrackingModel tracking_model(const TrackingExperimentConfig& c) {
  const double tau = c.dt_s;
  MatX F = MatX::Identity(4, 4);
  F.block<2, 2>(0, 2) = tau * Mat2::Identity();
  MatX W(4, 4);
  W << tau * tau * tau / 3 * Mat2::Identity(), tau * tau / 2 * Mat2::Identity(),
      tau * tau / 2 * Mat2::Identity(), tau * Mat2::Identity();
  W *= c.q;
  const Eigen::LLT<MatX> W_root(W);
  return TrackingModel{F, W, W_root};
}

/// Every sensor's range–bearing reading of target k (state y) at step t into its batch, and the reading's
/// information and score at the centralized mean into info_sum and score (§4.6 baseline).
void read_target(const TrackingExperimentConfig& c, const Graph& g, const VecX& y, int k, std::size_t t,
                 const VecX& central_mean, std::normal_distribution<double>& normal, std::mt19937_64& rng,
                 std::vector<estimators::MeasurementBatch>& batches, MatX& info_sum, VecX& score) {
  for (std::size_t i = 0; i < batches.size(); ++i) {
    const Vec2 d = y.head<2>() - g.positions[i];
    const double distance = d.norm();
    const double range_std = c.range_std_m + c.range_std_per_m * distance;
    const double bearing_std = c.bearing_std_rad + c.bearing_std_per_m * distance;
    const Vec2 z(distance + range_std * normal(rng),
                 models::wrap_angle(std::atan2(d.y(), d.x()) + bearing_std * normal(rng)));
    const Mat2 V = Vec2(range_std * range_std, bearing_std * bearing_std).asDiagonal();
    batches[i].targets = {estimators::TargetObservation{k, z, V, 1}};
    batches[i].world_step = static_cast<std::int64_t>(t);
    const auto r = models::range(g.positions[i], Vec2(central_mean.head<2>()));
    const auto b = models::bearing(g.positions[i], Vec2(central_mean.head<2>()));
    if (!r || !b) continue;
    MatX H = MatX::Zero(2, 4);
    H.block<1, 2>(0, 0) = r->d_xj;
    H.block<1, 2>(1, 0) = b->d_xj;
    const Vec2 residual(z(0) - r->value, models::bearing_residual(z(1), b->value));
    const MatX Vinv_H = V.inverse() * H;
    info_sum += H.transpose() * Vinv_H;
    score += Vinv_H.transpose() * residual;
  }
}

/// Target k of one run: a DLE per sensor and the centralized EKF track it for c.steps steps.
void track_target(const TrackingExperimentConfig& c, const Graph& g, const TrackingModel& model, int k,
                  std::normal_distribution<double>& normal, std::uniform_real_distribution<double>& heading,
                  std::mt19937_64& rng, TrackingSums& sums) {
  const auto steps = static_cast<std::size_t>(c.steps);
  const auto n = static_cast<std::size_t>(c.num_sensors);
  const MatX& F = model.F;
  const MatX& W = model.W;
  VecX y(4);
  const double angle = heading(rng);
  y << c.start_std_m * normal(rng), c.start_std_m * normal(rng), c.speed_mps * std::cos(angle),
      c.speed_mps * std::sin(angle);
  estimators::consensus::DleParams params;
  params.target = k;
  params.target_dim = 4;
  params.F = F;
  params.W = W;
  params.initial_information = c.initial_information;
  std::vector<std::unique_ptr<estimators::Estimator>> agents;
  std::vector<const estimators::consensus::Dle*> dle;
  for (std::size_t i = 0; i < n; ++i) {
    estimators::AgentSetup setup;
    setup.id = static_cast<int>(i);
    setup.initial_guess_m = g.positions[i];
    auto agent = std::make_unique<estimators::consensus::Dle>(setup, params);
    dle.push_back(agent.get());
    agents.push_back(std::move(agent));
  }
  detail::SyncBus bus(g.adjacency);
  bus.publish_initial(agents);
  std::vector<estimators::MeasurementBatch> batches(n);
  std::vector<const estimators::MeasurementBatch*> batch_ptrs;
  for (std::size_t i = 0; i < n; ++i) {
    for (const int j : g.adjacency[i]) batches[i].neighbours.push_back(j);
    batch_ptrs.push_back(&batches[i]);
  }
  // Centralized EKF in information form on every sensor's reading (§4.6 baseline).
  VecX central_mean = VecX::Zero(4);
  MatX central_info = c.initial_information * MatX::Identity(4, 4);
  for (std::size_t t = 1; t <= steps; ++t) {
    if (t > 1) {  // y(t) = F y(t−1) + η (Atanasov et al. eq. (1)); the first step observes the initial state
      VecX eta(4);
      for (int r = 0; r < 4; ++r) eta(r) = normal(rng);
      y = F * y + model.W_root.matrixL() * eta;
    }
    MatX info_sum = MatX::Zero(4, 4);
    VecX score = VecX::Zero(4);
    read_target(c, g, y, k, t, central_mean, normal, rng, batches, info_sum, score);
    bus.round(agents, static_cast<std::int64_t>(t), batch_ptrs);
    central_info += info_sum;
    central_mean += central_info.ldlt().solve(score);
    const auto tracked = [&](const VecX& estimate, std::vector<double>& pos, std::vector<double>& vel,
                             double weight) {
      pos[t] += weight * (estimate.head<2>() - y.head<2>()).squaredNorm();
      vel[t] += weight * (estimate.tail<2>() - y.tail<2>()).squaredNorm();
    };
    tracked(dle[0]->target_estimate(), sums.node0_pos, sums.node0_vel, 1.0);
    for (std::size_t i = 1; i < n; ++i)  // others: the mean over sensors 2…n of the squared error
      tracked(dle[i]->target_estimate(), sums.others_pos, sums.others_vel, 1.0 / static_cast<double>(n - 1));
    tracked(central_mean, sums.central_pos, sums.central_vel, 1.0);
    // Centralized prediction: P = F Λ⁻¹ Fᵀ + W.
    const MatX P = F * central_info.ldlt().solve(MatX::Identity(4, 4)) * F.transpose() + W;
    central_info = P.ldlt().solve(MatX::Identity(4, 4));
    central_mean = F * central_mean;
  }
}

}  // namespace

StaticDleExperimentResult run_static_dle_experiment(const StaticDleExperimentConfig& c) {
  if (c.num_nodes < 1 || c.steps < 1 || c.runs < 1 || c.target_dim < 1) {
    throw std::invalid_argument("static_dle_experiment: bad sizes");
  }
  std::mt19937_64 rng(c.seed);
  const auto steps = static_cast<std::size_t>(c.steps);
  StaticDleSums sums{std::vector<double>(steps + 1, 0.0), std::vector<double>(steps + 1, 0.0),
                     std::vector<double>(steps + 1, 0.0), std::vector<double>(steps + 1, 0.0)};
  std::normal_distribution<double> normal(0.0, 1.0);  // one for every run (it keeps a spare draw)
  for (int run = 0; run < c.runs; ++run) run_static_dle_once(c, rng, normal, sums);
  StaticDleExperimentResult result;
  result.mse.assign(steps + 1, kNaN);
  result.centralized_mse.assign(steps + 1, kNaN);
  result.centralized_crb.assign(steps + 1, kNaN);
  result.fraction_with_estimate.assign(steps + 1, 0.0);
  for (std::size_t t = 1; t <= steps; ++t) {
    if (sums.counted[t] > 0.0) result.mse[t] = sums.se[t] / sums.counted[t];
    result.centralized_mse[t] = sums.central_se[t] / c.runs;
    result.centralized_crb[t] = sums.central_crb[t] / c.runs;
    result.fraction_with_estimate[t] = sums.counted[t] / (static_cast<double>(c.runs) * c.num_nodes);
  }
  return result;
}

TrackingExperimentResult run_tracking_experiment(const TrackingExperimentConfig& c) {
  if (c.num_sensors < 2 || c.num_targets < 1 || c.steps < 1 || c.runs < 1)
    throw std::invalid_argument("tracking_experiment: bad sizes");
  std::mt19937_64 rng(c.seed);
  const auto steps = static_cast<std::size_t>(c.steps);
  const TrackingModel model = tracking_model(c);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> heading(0.0, 0.5 * std::numbers::pi);
  TrackingSums sums;
  for (auto* v : {&sums.node0_pos, &sums.others_pos, &sums.central_pos, &sums.node0_vel, &sums.others_vel,
                  &sums.central_vel})
    v->assign(steps + 1, 0.0);
  for (int run = 0; run < c.runs; ++run) {
    Graph g;
    for (int attempt = 0;; ++attempt) {
      if (attempt > 10000) throw std::runtime_error("tracking_experiment: no connected graph");
      auto points = uniform_points(c.num_sensors, c.side_m, rng);
      points[0] = Vec2::Zero();  // node 1 of the paper at the origin
      g = make_graph(points, c.radius_m);
      if (detail::connected(g.adjacency)) break;
    }
    for (int k = 0; k < c.num_targets; ++k) track_target(c, g, model, k, normal, heading, rng, sums);
  }
  const double denom = static_cast<double>(c.runs) * c.num_targets;
  TrackingExperimentResult result;
  auto finish = [&](const std::vector<double>& sums_t, std::vector<double>& out) {
    out.assign(steps + 1, kNaN);
    for (std::size_t t = 1; t <= steps; ++t) out[t] = std::sqrt(sums_t[t] / denom);
  };
  finish(sums.node0_pos, result.node0_position_rmse);
  finish(sums.others_pos, result.others_position_rmse);
  finish(sums.central_pos, result.centralized_position_rmse);
  finish(sums.node0_vel, result.node0_velocity_rmse);
  finish(sums.others_vel, result.others_velocity_rmse);
  finish(sums.central_vel, result.centralized_velocity_rmse);
  return result;
}

}  // namespace swarmloc::research
