#include "swarmloc/estimators/dml/local_map.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>

#include "swarmloc/estimators/self_check.hpp"

namespace swarmloc::estimators::local_map {
namespace {

constexpr double kUnreached = std::numeric_limits<double>::infinity();
constexpr int kRefineIterations = 40;
constexpr double kShortestRangeM = 1e-9;
constexpr double kSeparationSigmas = 6.0;  // two fitting maps this far apart place the agent differently
constexpr double kSingularPivot = 1e-12;   // relative to the largest: a map that does not fix a node

template <int D>
using Coordinates = std::vector<VecD<D>>;

template <int D>
bool usable_range(const Range& range, const std::vector<NodeT<D>>& nodes) {
  const auto a = static_cast<std::size_t>(range.first);
  const auto b = static_cast<std::size_t>(range.second);
  return range.first >= 0 && range.second >= 0 && a < nodes.size() && b < nodes.size() && a != b &&
         range.information > 0.0 && range.range_m > 0.0;
}

/// The nodes a map keeps: every known node, and the nodes to place that keep `minimum` ranges to kept nodes.
template <int D>
std::vector<bool> ranged_at_least(const std::vector<NodeT<D>>& nodes, const std::vector<Range>& ranges,
                                  int minimum) {
  std::vector<bool> kept(nodes.size(), true);
  for (bool changed = true; changed;) {
    changed = false;
    std::vector<int> degree(nodes.size(), 0);
    for (const auto& range : ranges) {
      if (!usable_range(range, nodes)) continue;
      const auto a = static_cast<std::size_t>(range.first);
      const auto b = static_cast<std::size_t>(range.second);
      if (kept[a] && kept[b]) {
        ++degree[a];
        ++degree[b];
      }
    }
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      if (kept[i] && !nodes[i].known && degree[i] < minimum) {
        kept[i] = false;
        changed = true;
      }
    }
  }
  return kept;
}

/// Every pair's distance: measured where ranged, exact between known nodes, else the shortest path
/// through the ranges (an overestimate the refinement removes). Empty if a node is unreached.
template <int D>
MatX completed_distances(const std::vector<NodeT<D>>& nodes, const std::vector<Range>& ranges) {
  const auto n = static_cast<Eigen::Index>(nodes.size());
  MatX distance = MatX::Constant(n, n, kUnreached);
  for (Eigen::Index i = 0; i < n; ++i) {
    distance(i, i) = 0.0;
    const auto& a = nodes[static_cast<std::size_t>(i)];
    for (Eigen::Index j = 0; j < i && a.known; ++j) {
      const auto& b = nodes[static_cast<std::size_t>(j)];
      if (b.known) distance(i, j) = distance(j, i) = (a.position_m - b.position_m).norm();
    }
  }
  for (const auto& range : ranges)
    distance(range.first, range.second) = distance(range.second, range.first) = range.range_m;
  for (Eigen::Index k = 0; k < n; ++k) {
    for (Eigen::Index i = 0; i < n; ++i) {
      for (Eigen::Index j = 0; j < n; ++j)
        distance(i, j) = std::min(distance(i, j), distance(i, k) + distance(k, j));
    }
  }
  return distance.allFinite() ? distance : MatX();
}

/// Classical scaling: the D leading eigenvectors of the double-centred squared distances.
template <int D>
Coordinates<D> scaled_coordinates(const MatX& distance) {
  const Eigen::Index n = distance.rows();
  const MatX centring = MatX::Identity(n, n) - MatX::Constant(n, n, 1.0 / static_cast<double>(n));
  const MatX gram = -0.5 * centring * distance.cwiseProduct(distance) * centring;
  const Eigen::SelfAdjointEigenSolver<MatX> eigen(gram);
  Coordinates<D> coordinates(static_cast<std::size_t>(n), VecD<D>::Zero());
  for (int axis = 0; axis < D; ++axis) {
    const Eigen::Index column = n - 1 - axis;  // eigenvalues ascending
    const double scale = std::sqrt(std::max(0.0, eigen.eigenvalues()(column)));
    for (Eigen::Index i = 0; i < n; ++i)
      coordinates[static_cast<std::size_t>(i)](axis) = scale * eigen.eigenvectors()(i, column);
  }
  return coordinates;
}

/// The map moved onto the known nodes by the best rotation (first) and the best reflection (second).
template <int D>
std::pair<Coordinates<D>, Coordinates<D>> fitted_to_known(const Coordinates<D>& map,
                                                          const std::vector<NodeT<D>>& nodes) {
  VecD<D> map_centre = VecD<D>::Zero();
  VecD<D> world_centre = VecD<D>::Zero();
  double known = 0.0;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    if (!nodes[i].known) continue;
    map_centre += map[i];
    world_centre += nodes[i].position_m;
    known += 1.0;
  }
  map_centre /= known;
  world_centre /= known;
  MatD<D> cross = MatD<D>::Zero();
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    if (nodes[i].known) cross += (map[i] - map_centre) * (nodes[i].position_m - world_centre).transpose();
  }
  const Eigen::JacobiSVD<MatD<D>> svd(cross, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const double handedness = (svd.matrixV() * svd.matrixU().transpose()).determinant() > 0.0 ? 1.0 : -1.0;
  const auto moved = [&](double sign) {
    VecD<D> axes = VecD<D>::Ones();
    axes(D - 1) = sign;  // the last axis turned over: the reflection
    const MatD<D> turn = svd.matrixV() * axes.asDiagonal() * svd.matrixU().transpose();
    Coordinates<D> out(map.size());
    for (std::size_t i = 0; i < map.size(); ++i)
      out[i] = nodes[i].known ? nodes[i].position_m : VecD<D>(world_centre + turn * (map[i] - map_centre));
    return out;
  };
  return {moved(handedness), moved(-handedness)};
}

/// Levenberg–Marquardt on the ranges with the known nodes held: the cost Σ W (r − ‖x_a − x_b‖)².
template <int D>
struct Refined {
  Coordinates<D> x;
  double cost;
  MatX information;  // Gauss–Newton, over the unknown nodes' coordinates
};

template <int D>
double range_cost(const Coordinates<D>& x, const std::vector<Range>& ranges) {
  double cost = 0.0;
  for (const auto& range : ranges) {
    const double residual =
        range.range_m -
        (x[static_cast<std::size_t>(range.first)] - x[static_cast<std::size_t>(range.second)]).norm();
    cost += range.information * residual * residual;
  }
  return cost;
}

/// The Gauss–Newton normal equations of the range cost at `at`, over the unknown nodes' coordinates.
template <int D>
void normal_equations(const Coordinates<D>& at, const std::vector<Range>& ranges,
                      const std::vector<int>& unknown_index, Eigen::Index size, MatX& hessian,
                      VecX& gradient) {
  hessian = MatX::Zero(size, size);
  gradient = VecX::Zero(size);
  for (const auto& range : ranges) {
    const auto a = static_cast<std::size_t>(range.first);
    const auto b = static_cast<std::size_t>(range.second);
    const VecD<D> offset = at[a] - at[b];
    const double length = offset.norm();
    if (length < kShortestRangeM) continue;
    const VecD<D> direction = offset / length;
    const double residual = range.range_m - length;
    const int ends[2] = {unknown_index[a], unknown_index[b]};
    const double signs[2] = {1.0, -1.0};
    for (int p = 0; p < 2; ++p) {
      if (ends[p] < 0) continue;
      gradient.template segment<D>(D * ends[p]) += signs[p] * range.information * residual * direction;
      for (int q = 0; q < 2; ++q) {
        if (ends[q] < 0) continue;
        hessian.template block<D, D>(D * ends[p], D * ends[q]) +=
            signs[p] * signs[q] * range.information * direction * direction.transpose();
      }
    }
  }
}

template <int D>
Refined<D> refined(Coordinates<D> x, const std::vector<NodeT<D>>& nodes, const std::vector<Range>& ranges,
                   const std::vector<int>& unknown_index) {
  const auto size = static_cast<Eigen::Index>(
      D * std::count_if(nodes.begin(), nodes.end(), [](const NodeT<D>& n) { return !n.known; }));
  const auto normal_equations_at = [&](const Coordinates<D>& at, MatX& hessian, VecX& gradient) {
    normal_equations<D>(at, ranges, unknown_index, size, hessian, gradient);
  };
  double cost = range_cost<D>(x, ranges);
  double damping = 1e-3;
  MatX hessian;
  VecX gradient;
  for (int iteration = 0; iteration < kRefineIterations; ++iteration) {
    normal_equations_at(x, hessian, gradient);
    const MatX damped =
        hessian + damping * MatX(hessian.diagonal().asDiagonal()) + 1e-12 * MatX::Identity(size, size);
    const VecX step = damped.ldlt().solve(gradient);
    Coordinates<D> trial = x;
    for (std::size_t i = 0; i < x.size(); ++i) {
      if (unknown_index[i] >= 0) trial[i] += step.template segment<D>(D * unknown_index[i]);
    }
    const double trial_cost = range_cost<D>(trial, ranges);
    if (trial_cost < cost) {
      const bool settled = cost - trial_cost < 1e-12 * (1.0 + cost);
      x = std::move(trial);
      cost = trial_cost;
      damping = std::max(1e-9, damping / 10.0);
      if (settled) break;
    } else {
      damping *= 10.0;
      if (damping > 1e9) break;
    }
  }
  normal_equations_at(x, hessian, gradient);
  return {std::move(x), cost, std::move(hessian)};
}

}  // namespace

template <int D>
std::optional<MatD<D>> covariance_at(const std::vector<NodeT<D>>& nodes, const std::vector<Range>& ranges) {
  if (nodes.empty() || nodes.front().known) return std::nullopt;
  std::vector<Range> usable;
  for (const auto& range : ranges) {
    if (usable_range(range, nodes)) usable.push_back(range);
  }
  // A node to place held by fewer than D ranges turns freely about their other ends and informs no one.
  const std::vector<bool> kept = ranged_at_least(nodes, usable, D);
  if (!kept.front()) return std::nullopt;
  std::vector<int> unknown_index(nodes.size(), -1);
  int unknowns = 0;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    if (kept[i] && !nodes[i].known) unknown_index[i] = unknowns++;
  }
  Coordinates<D> at(nodes.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) at[i] = nodes[i].position_m;
  std::vector<Range> used;
  for (const auto& range : usable) {
    if (kept[static_cast<std::size_t>(range.first)] && kept[static_cast<std::size_t>(range.second)])
      used.push_back(range);
  }
  MatX information;
  VecX gradient;
  normal_equations<D>(at, used, unknown_index, D * unknowns, information, gradient);
  const Eigen::LDLT<MatX> factor(information);
  if (factor.info() != Eigen::Success) return std::nullopt;
  const VecX pivots = factor.vectorD();
  if (!(pivots.minCoeff() > kSingularPivot * pivots.maxCoeff())) return std::nullopt;
  // Node 0 is unknown index 0: its marginal is the top-left block of the inverse.
  MatX unit = MatX::Zero(information.rows(), D);
  unit.template topRows<D>().setIdentity();
  const MatD<D> covariance = factor.solve(unit).template topRows<D>();
  return MatD<D>(0.5 * (covariance + covariance.transpose()));
}

template <int D>
std::optional<PlacementT<D>> place(const std::vector<NodeT<D>>& nodes, const std::vector<Range>& ranges,
                                   double false_alarm, double max_std_m,
                                   const std::vector<VecD<D>>& agent_starts, double mirror_gap) {
  if (nodes.empty() || nodes.front().known) return std::nullopt;
  // One held by D ranges can flip across the line (plane) through their other ends, and the ranges cannot
  // tell.
  const std::vector<bool> kept = ranged_at_least(nodes, ranges, D + 1);
  if (!kept.front()) return std::nullopt;
  std::vector<int> compact(nodes.size(), -1);
  std::vector<NodeT<D>> map;
  std::vector<int> unknown_index;
  int unknowns = 0;
  int known = 0;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    if (!kept[i]) continue;
    compact[i] = static_cast<int>(map.size());
    map.push_back(nodes[i]);
    unknown_index.push_back(nodes[i].known ? -1 : unknowns++);
    known += nodes[i].known ? 1 : 0;
  }
  // Only ranges that touch a node to place test the map (those between known nodes are fixed data).
  std::vector<Range> used;
  for (const auto& range : ranges) {
    if (!usable_range(range, nodes)) continue;
    const int a = compact[static_cast<std::size_t>(range.first)];
    const int b = compact[static_cast<std::size_t>(range.second)];
    if (a < 0 || b < 0 || (map[static_cast<std::size_t>(a)].known && map[static_cast<std::size_t>(b)].known))
      continue;
    used.push_back({a, b, range.range_m, range.information});
  }
  const int dof = static_cast<int>(used.size()) - D * unknowns;
  if (known < D || dof < 1) return std::nullopt;
  const MatX distance = completed_distances(map, used);
  if (distance.size() == 0) return std::nullopt;
  const auto [rotated, reflected] = fitted_to_known<D>(scaled_coordinates<D>(distance), map);
  Coordinates<D> guessed(map.size());
  for (std::size_t i = 0; i < map.size(); ++i) guessed[i] = map[i].position_m;
  // Three starts: the scaled map both ways round, and the agents' own guesses. Each ends in a minimum;
  // the best must fit the ranges, and no other that fits them may put this agent elsewhere.
  std::vector<Refined<D>> minima;
  for (const Coordinates<D>* start : {&rotated, &reflected, static_cast<const Coordinates<D>*>(&guessed)})
    minima.push_back(refined<D>(*start, map, used, unknown_index));
  for (const VecD<D>& agent_start : agent_starts) {
    Coordinates<D> start = guessed;
    start.front() = agent_start;
    minima.push_back(refined<D>(start, map, used, unknown_index));
  }
  std::sort(minima.begin(), minima.end(),
            [](const Refined<D>& a, const Refined<D>& b) { return a.cost < b.cost; });
  const Refined<D>& best = minima.front();
  const double threshold = chi_square_upper_quantile(dof, false_alarm);
  if (!(best.cost <= threshold)) return std::nullopt;
  const Eigen::LDLT<MatX> factor(best.information);
  if (factor.info() != Eigen::Success || !(factor.vectorD().minCoeff() > 0.0)) return std::nullopt;
  const MatD<D> covariance = factor.solve(MatX::Identity(best.information.rows(), best.information.rows()))
                                 .template topLeftCorner<D, D>();
  const double largest_std =
      std::sqrt(Eigen::SelfAdjointEigenSolver<MatD<D>>(covariance).eigenvalues()(D - 1));
  if (!(largest_std <= max_std_m)) return std::nullopt;
  PlacementT<D> placement{best.x.front(), std::nullopt};
  for (std::size_t k = 1; k < minima.size() && !placement.alternative_m; ++k) {
    if (minima[k].cost <= std::max(threshold, best.cost + mirror_gap) &&
        (minima[k].x.front() - best.x.front()).norm() > kSeparationSigmas * largest_std) {
      placement.alternative_m = minima[k].x.front();
    }
  }
  return placement;
}

template std::optional<PlacementT<2>> place(const std::vector<NodeT<2>>&, const std::vector<Range>&, double,
                                            double, const std::vector<Vec2>&, double);
template std::optional<PlacementT<3>> place(const std::vector<NodeT<3>>&, const std::vector<Range>&, double,
                                            double, const std::vector<Vec3>&, double);
template std::optional<Mat2> covariance_at(const std::vector<NodeT<2>>&, const std::vector<Range>&);
template std::optional<Mat3> covariance_at(const std::vector<NodeT<3>>&, const std::vector<Range>&);

}  // namespace swarmloc::estimators::local_map
