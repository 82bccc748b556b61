#include "swarmloc/world/bound.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>

namespace swarmloc::world {
namespace {

constexpr double kNoBound = std::numeric_limits<double>::quiet_NaN();
constexpr double kUnbounded = std::numeric_limits<double>::infinity();
/// As scenario_crlb: the dense 2n x 2n Fisher inverse is not computed beyond this many unknowns.
constexpr long kMaxDenseBoundUnknowns = 1000;
/// The PCRB inverts two dense (2n)² matrices per step: beyond ~steps·(2n)³ of this it would delay the run
/// start by more than a few seconds.
constexpr double kMaxPcrbWork = 5e9;

using enum config::RangeDraws;
using enum config::AnchorData;

/// The row of one registry entry: the table of which data every algorithm receives is the registry's
/// (config/algorithms.cpp, docs/algorithms.md §1.3.1).
BoundData row_of(const config::AlgorithmSpec& spec) {
  return BoundData{spec.name, spec.bound.model, spec.bound.draws, spec.bound.anchors, spec.bound.none_reason};
}

bool anchors_in_state(const config::Scenario& s, AnchorData anchors) {
  return anchors == kFixes && s.noise.anchor_fix_std_m > 0.0;
}

/// How many of an edge's draws the data holds: `at_lo`/`at_hi` say whether each end's draw is used.
int draws_used(bool at_lo, bool at_hi, bool shared) {
  if (shared) return (at_lo || at_hi) ? 1 : 0;  // both ends hold the same value: it counts once
  return (at_lo ? 1 : 0) + (at_hi ? 1 : 0);
}

/// Offsets of the network's unknowns in θ (−1: known anchor), as estimators::range_network_fisher orders
/// them.
template <int D>
std::vector<Eigen::Index> state_offsets(const estimators::RangeNetworkOf<D>& network) {
  std::vector<Eigen::Index> offset(network.truth.size(), -1);
  Eigen::Index next = 0;
  for (std::size_t i = 0; i < network.truth.size(); ++i) {
    if (!network.is_anchor[i]) offset[i] = next, next += D;
  }
  return offset;
}

/// Mean over the world's non-anchors of the static network's CRB (+inf if one is not localizable); D
/// coordinates per agent.
template <int D>
double static_network_rmse(const estimators::RangeNetworkOf<D>& network,
                           const std::vector<bool>& world_anchor) {
  const auto crlb = estimators::network_crlb(network);
  double total = 0.0;
  int scored = 0;
  for (std::size_t i = 0; i < world_anchor.size(); ++i) {
    if (world_anchor[i]) continue;
    const double rmse = crlb.per_agent_rmse_m[i];
    if (!std::isfinite(rmse)) return kUnbounded;
    total += rmse * rmse;
    ++scored;
  }
  return scored > 0 ? std::sqrt(total / scored) : 0.0;
}

/// J_0's prior: the spread of the world's initial guesses (noisy_truth: initial_guess_std_m² I; uniform:
/// the placement's area_m²/12 I) for every agent in θ, the anchors with fixes included.
template <int D>
std::vector<Eigen::Matrix<double, D, D>> prior_information(const World& world, const config::Scenario& s) {
  return std::vector<Eigen::Matrix<double, D, D>>(
      static_cast<std::size_t>(world.size()),
      Eigen::Matrix<double, D, D>::Identity() / start_prior_variance(s));
}

template <int D>
double non_anchor_rmse_of(const MatX& covariance, const estimators::RangeNetworkOf<D>& network,
                          const std::vector<bool>& world_anchor) {
  const auto offset = state_offsets<D>(network);
  double total = 0.0;
  int scored = 0;
  for (std::size_t i = 0; i < offset.size(); ++i) {
    if (world_anchor[i] || offset[i] < 0) continue;
    total += covariance.diagonal().segment<D>(offset[i]).sum();
    ++scored;
  }
  return scored > 0 ? std::sqrt(std::max(0.0, total) / scored) : 0.0;
}

/// snapshot_network in D dimensions: `truth` holds each agent's position (with its z in 3-D).
template <int D>
estimators::RangeNetworkOf<D> snapshot_network_of(const World& world, const config::Scenario& s,
                                                  const std::vector<Eigen::Matrix<double, D, 1>>& truth,
                                                  RangeDraws draws, AnchorData anchors) {
  estimators::RangeNetworkOf<D> network;
  network.truth = truth;
  const bool anchors_unknown = anchors_in_state(s, anchors);
  network.is_anchor = anchors_unknown ? std::vector<bool>(truth.size(), false) : world.is_anchor;
  for (int lo = 0; lo < world.size(); ++lo) {
    for (const AgentId hi : world.neighbours[static_cast<std::size_t>(lo)]) {
      if (hi <= lo) continue;
      const double distance =
          (truth[static_cast<std::size_t>(lo)] - truth[static_cast<std::size_t>(hi)]).norm();
      if (distance > s.world.comm_radius_m) continue;  // moved out of range: not measured (generate_batch)
      const double std_m = std::max(1e-9, s.noise.range_std_at(distance));
      const bool at_lo = draws != kOwnDraws || !world.is_anchor[static_cast<std::size_t>(lo)];
      const bool at_hi =
          draws == kAllDraws || (draws == kOwnDraws && !world.is_anchor[static_cast<std::size_t>(hi)]);
      for (int k = draws_used(at_lo, at_hi, s.noise.shared_range_draws); k > 0; --k)
        network.ranges.push_back({lo, hi, std_m});
    }
  }
  if (anchors_unknown) {
    const double variance = s.noise.anchor_fix_std_m * s.noise.anchor_fix_std_m;
    for (int i = 0; i < world.size(); ++i) {
      if (world.is_anchor[static_cast<std::size_t>(i)])
        network.absolute.push_back({i, Eigen::Matrix<double, D, D>::Identity() * variance});
    }
  }
  return network;
}

/// The PCRB series along the truth `trajectory` (one position list per world step, D coordinates each).
template <int D>
std::vector<double> pcrb_series(const World& world, const config::Scenario& s,
                                const std::vector<std::vector<Eigen::Matrix<double, D, 1>>>& trajectory,
                                RangeDraws draws, AnchorData anchors) {
  std::vector<double> series;
  series.reserve(trajectory.size());
  const auto prior = prior_information<D>(world, s);
  const double motion_variance = s.world.motion_std_m * s.world.motion_std_m;
  MatX information;
  VecX process_variance;
  for (std::size_t k = 0; k < trajectory.size(); ++k) {
    const auto network = snapshot_network_of<D>(world, s, trajectory[k], draws, anchors);
    if (k == 0) {
      information = estimators::range_network_fisher(network, 1.0, &prior);
      // The world's random walk moves the non-anchors only, in every coordinate (world.cpp advance_truth).
      process_variance = VecX::Zero(information.rows());
      const auto offset = state_offsets<D>(network);
      for (std::size_t i = 0; i < offset.size(); ++i) {
        if (offset[i] >= 0 && !world.is_anchor[i])
          process_variance.segment<D>(offset[i]).setConstant(motion_variance);
      }
    } else {
      information = pcrb_predict(information, process_variance) + estimators::range_network_fisher(network);
    }
    const Eigen::LLT<MatX> llt(information);
    series.push_back(
        llt.info() == Eigen::Success
            ? non_anchor_rmse_of<D>(llt.solve(MatX::Identity(information.rows(), information.cols())),
                                    network, world.is_anchor)
            : kUnbounded);
  }
  return series;
}

RunBound no_bound(RunBound bound, std::string reason) {
  bound.kind = BoundKind::kNone;
  bound.reason = std::move(reason);
  return bound;
}

/// The static network's single-snapshot RMSE bound of `draws`: planar, or in space in a 3-D world (3
/// coordinates per agent).
double static_snapshot_rmse(const World& world, const config::Scenario& s, RangeDraws draws,
                            AnchorData anchors) {
  if (world.dimensions == 3)
    return static_network_rmse(snapshot_network3(world, s, true_positions3(world), draws, anchors),
                               world.is_anchor);
  return static_network_rmse(snapshot_network(world, s, world.truth, draws, anchors), world.is_anchor);
}

RunBound static_range_bound(RunBound bound, const World& world, const config::Scenario& s,
                            const RangeCrlb& legacy) {
  bound.kind = BoundKind::kCrlbStaticAccumulated;
  bound.fresh_draws_per_step = s.noise.draw == config::NoiseDraw::kPerStep;
  bound.single_rmse_m = static_snapshot_rmse(world, s, bound.draws, bound.anchors);
  if (bound.draws == kAllDraws) {
    bound.all_data_single_rmse_m = bound.single_rmse_m;
  } else if (!anchors_in_state(s, bound.anchors)) {
    // scenario_crlb's is this bound (every draw, known anchors): not computed twice.
    bound.all_data_single_rmse_m = legacy.single_snapshot_rmse_m;
  } else {
    bound.all_data_single_rmse_m = static_snapshot_rmse(world, s, kAllDraws, bound.anchors);
  }
  if (!std::isfinite(bound.single_rmse_m))
    return no_bound(bound, "not localizable from the algorithm's data");
  return bound;
}

template <int D>
RunBound moving_range_bound(RunBound bound, const World& world, const config::Scenario& s) {
  if (s.noise.draw == config::NoiseDraw::kOnce)
    return no_bound(bound, "moving truth with noise.draw = once (repeated draws): no bound implemented");
  const auto unknowns = static_cast<double>(
      anchors_in_state(s, bound.anchors) ? world.size() : world.size() - world.anchor_count());
  const double dimension = D * unknowns;
  if (static_cast<double>(s.run.steps) * dimension * dimension * dimension > kMaxPcrbWork)
    return no_bound(bound, "posterior CRB too costly for this size and run length (dense, O(steps·n³))");
  // The trajectory the run will see: advance_truth is seeded by (seed, trial, step).
  World replay = world;
  // A recorded world (replay of a --record directory) holds its own number of steps.
  const std::int64_t steps =
      world.recorded ? std::min<std::int64_t>(s.run.steps, world.recorded->steps()) : s.run.steps;
  std::vector<std::vector<Eigen::Matrix<double, D, 1>>> trajectory;
  trajectory.reserve(static_cast<std::size_t>(steps));
  for (std::int64_t step = 0; step < steps; ++step) {
    if (step > 0) advance_truth(replay, s, step);
    if constexpr (D == 3) {
      trajectory.push_back(true_positions3(replay));
    } else {
      trajectory.push_back(replay.truth);
    }
  }
  bound.kind = BoundKind::kPcrb;
  bound.pcrb_rmse_m = pcrb_series<D>(world, s, trajectory, bound.draws, bound.anchors);
  bound.all_data_pcrb_rmse_m = bound.draws == kAllDraws
                                   ? bound.pcrb_rmse_m
                                   : pcrb_series<D>(world, s, trajectory, kAllDraws, bound.anchors);
  return bound;
}

/// A moving target (Atanasov et al. eq. (1)): the tracking PCRB of docs/algorithms.md §1.3,
/// J_{k+1} = (F J_k⁻¹ Fᵀ + W)⁻¹ + I(y(k+1)), I from every sensor's reading (all the data: every sensor
/// estimates the same target). The target's start is a scenario constant no estimator is told, so J_0's
/// prior is diffuse (kDiffuseTargetInformation).
RunBound moving_target_bound(RunBound bound, const World& world, const config::Scenario& s) {
  constexpr double kDiffuseTargetInformation = 1e-6;
  const config::TargetModel model = config::target_model(s);
  World replay = world;
  MatX information = MatX::Identity(model.dim, model.dim) * kDiffuseTargetInformation;
  bound.pcrb_rmse_m.reserve(static_cast<std::size_t>(s.run.steps));
  for (std::int64_t step = 0; step < s.run.steps; ++step) {
    if (step > 0) {
      advance_truth(replay, s, step);
      const MatX covariance = Eigen::LLT<MatX>(information).solve(MatX::Identity(model.dim, model.dim));
      information = Eigen::LLT<MatX>(model.F * covariance * model.F.transpose() + model.W)
                        .solve(MatX::Identity(model.dim, model.dim));
    }
    information.topLeftCorner<2, 2>() += target_information(replay, s, replay.target.head<2>());
    const MatX covariance = Eigen::LLT<MatX>(information).solve(MatX::Identity(model.dim, model.dim));
    bound.pcrb_rmse_m.push_back(std::sqrt(std::max(0.0, covariance.topLeftCorner<2, 2>().trace())));
  }
  bound.kind = BoundKind::kPcrb;
  bound.all_data_pcrb_rmse_m = bound.pcrb_rmse_m;
  return bound;
}

}  // namespace

const std::vector<BoundData>& bound_data_table() {
  static const std::vector<BoundData> table = [] {
    std::vector<BoundData> rows;
    for (const auto& spec : config::algorithm_registry()) rows.push_back(row_of(spec));
    return rows;
  }();
  return table;
}

BoundData bound_data(const std::string& algorithm) {
  if (const config::AlgorithmSpec* spec = config::find_algorithm(algorithm)) return row_of(*spec);
  return BoundData{{}, BoundModel::kNone, kAllDraws, kKnown, "no bound data declared for this algorithm"};
}

std::string_view to_string(BoundKind kind) {
  switch (kind) {
    case BoundKind::kCrlbStaticAccumulated:
      return "crlb_static_accumulated";
    case BoundKind::kPcrb:
      return "pcrb";
    case BoundKind::kNone:
      break;
  }
  return "none";
}

std::string_view to_string(RangeDraws draws) {
  switch (draws) {
    case kOnePerEdge:
      return "one_per_edge";
    case kOwnDraws:
      return "own_draws";
    case kAllDraws:
      break;
  }
  return "all_draws";
}

std::string_view to_string(AnchorData anchors) { return anchors == kFixes ? "fixes" : "known"; }

double RunBound::rmse_at(std::int64_t step) const {
  if (kind == BoundKind::kPcrb)
    return step >= 0 && static_cast<std::size_t>(step) < pcrb_rmse_m.size()
               ? pcrb_rmse_m[static_cast<std::size_t>(step)]
               : kNoBound;
  if (kind != BoundKind::kCrlbStaticAccumulated) return kNoBound;
  return fresh_draws_per_step ? single_rmse_m / std::sqrt(static_cast<double>(step + 1)) : single_rmse_m;
}

double RunBound::all_data_rmse_at(std::int64_t step) const {
  if (kind == BoundKind::kPcrb)
    return step >= 0 && static_cast<std::size_t>(step) < all_data_pcrb_rmse_m.size()
               ? all_data_pcrb_rmse_m[static_cast<std::size_t>(step)]
               : kNoBound;
  if (kind != BoundKind::kCrlbStaticAccumulated) return kNoBound;
  return fresh_draws_per_step ? all_data_single_rmse_m / std::sqrt(static_cast<double>(step + 1))
                              : all_data_single_rmse_m;
}

estimators::RangeNetwork snapshot_network(const World& world, const config::Scenario& s,
                                          const std::vector<Vec2>& truth, RangeDraws draws,
                                          AnchorData anchors) {
  return snapshot_network_of<2>(world, s, truth, draws, anchors);
}

estimators::RangeNetwork3 snapshot_network3(const World& world, const config::Scenario& s,
                                            const std::vector<Vec3>& truth, RangeDraws draws,
                                            AnchorData anchors) {
  return snapshot_network_of<3>(world, s, truth, draws, anchors);
}

std::vector<Vec3> true_positions3(const World& world) {
  std::vector<Vec3> positions;
  positions.reserve(static_cast<std::size_t>(world.size()));
  for (AgentId i = 0; i < world.size(); ++i) positions.push_back(world.position3(i));
  return positions;
}

double non_anchor_rmse(const MatX& covariance, const estimators::RangeNetwork& network,
                       const std::vector<bool>& world_anchor) {
  return non_anchor_rmse_of<2>(covariance, network, world_anchor);
}

MatX pcrb_predict(const MatX& information, const VecX& process_variance) {
  const Eigen::Index n = information.rows();
  MatX predicted = Eigen::LLT<MatX>(information).solve(MatX::Identity(n, n));
  predicted.diagonal() += process_variance;
  return Eigen::LLT<MatX>(predicted).solve(MatX::Identity(n, n));
}

RunBound run_bound(const World& world, const config::Scenario& s, const RangeCrlb& legacy) {
  const BoundData data = bound_data(s.algorithm.name);
  RunBound bound;
  bound.draws = data.draws;
  bound.anchors = data.anchors;
  if (s.world.source == config::WorldSource::kMrclam)
    return no_bound(bound, "real data (world.source = mrclam): its noise is not a known model");
  if (data.model == BoundModel::kNone) return no_bound(bound, std::string(data.none_reason));
  if (data.model == BoundModel::kScenario) {
    if (measurement_kinds(s.algorithm.name).targets && s.world.target_motion != config::TargetMotion::kStatic)
      return moving_target_bound(bound, world, s);
    if (truth_moves(s))
      return no_bound(bound, "moving agents: the posterior CRB is implemented for ranges and targets only");
    if (world.dimensions == 3 && std::isnan(legacy.single_snapshot_rmse_m))
      return no_bound(bound, "3-D world: the bound is implemented for ranges only");
    if (std::isnan(legacy.single_snapshot_rmse_m))
      return no_bound(bound,
                      "no bound: not implemented for this measurement model, or the world is too large");
    if (!std::isfinite(legacy.single_snapshot_rmse_m)) return no_bound(bound, "not localizable");
    bound.kind = BoundKind::kCrlbStaticAccumulated;
    bound.single_rmse_m = bound.all_data_single_rmse_m = legacy.single_snapshot_rmse_m;
    bound.fresh_draws_per_step = legacy.fresh_draws_per_step;
    return bound;
  }
  if (world.size() - world.anchor_count() > kMaxDenseBoundUnknowns)
    return no_bound(bound, "more than 1000 unknown agents: the dense bound is not computed");
  if (!truth_moves(s)) return static_range_bound(bound, world, s, legacy);
  return world.dimensions == 3 ? moving_range_bound<3>(bound, world, s)
                               : moving_range_bound<2>(bound, world, s);
}

bool truth_moves(const config::Scenario& scenario) {
  return scenario.world.motion == config::Motion::kRandomWalk && scenario.world.motion_std_m > 0.0;
}

double start_prior_variance(const config::Scenario& scenario) {
  /// A noisy_truth start with initial_guess_std_m = 0 is exact; this floor keeps J_0 finite.
  constexpr double kMinPriorVariance = 1e-12;
  const auto& w = scenario.world;
  return w.initial_guess == config::InitialGuess::kUniform
             ? w.area_m * w.area_m / 12.0
             : std::max(kMinPriorVariance, w.initial_guess_std_m * w.initial_guess_std_m);
}

}  // namespace swarmloc::world
