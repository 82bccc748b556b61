#pragma once
// The batch maximum-likelihood solution of every range draw of a network, by dense Gauss–Newton from the
// truth with the anchors held: the reference dml's tests compare its fixed point and covariance with.
#include <cstddef>
#include <tuple>
#include <utility>
#include <vector>

#include "swarmloc/core/types.hpp"

namespace swarmloc::testing {

/// Minimizes Σ (r − ‖x_i − x_j‖)²/σ² over `draws` (agent, peer, range), in D dimensions. Returns the solution
/// and the Fisher information at it (the unknowns' coordinates in agent order).
template <int D>
std::pair<std::vector<Eigen::Matrix<double, D, 1>>, MatX> dense_range_ml(
    const std::vector<Eigen::Matrix<double, D, 1>>& truth, const std::vector<bool>& anchor,
    const std::vector<std::tuple<int, int, double>>& draws, double std_m) {
  using Point = Eigen::Matrix<double, D, 1>;
  std::vector<int> slot(truth.size(), -1);
  int unknowns = 0;
  for (std::size_t i = 0; i < truth.size(); ++i)
    if (!anchor[i]) slot[i] = unknowns++;
  std::vector<Point> x = truth;
  MatX fisher;
  for (int iteration = 0; iteration < 50; ++iteration) {
    fisher = MatX::Zero(D * unknowns, D * unknowns);
    VecX gradient = VecX::Zero(D * unknowns);
    for (const auto& [i, j, range] : draws) {
      const Point offset = x[static_cast<std::size_t>(i)] - x[static_cast<std::size_t>(j)];
      const Point a = offset.normalized();
      const double weight = 1.0 / (std_m * std_m);
      const double residual = range - offset.norm();
      for (const auto& [node, sign] : {std::pair{i, 1.0}, std::pair{j, -1.0}}) {
        const int s = slot[static_cast<std::size_t>(node)];
        if (s < 0) continue;
        gradient.template segment<D>(D * s) += weight * residual * sign * a;
        for (const auto& [other, other_sign] : {std::pair{i, 1.0}, std::pair{j, -1.0}}) {
          const int t = slot[static_cast<std::size_t>(other)];
          if (t >= 0)
            fisher.template block<D, D>(D * s, D * t) += weight * sign * other_sign * a * a.transpose();
        }
      }
    }
    const VecX step = fisher.ldlt().solve(gradient);
    for (std::size_t i = 0; i < x.size(); ++i)
      if (slot[i] >= 0) x[i] += step.template segment<D>(D * slot[i]);
  }
  return {x, fisher};
}

}  // namespace swarmloc::testing
