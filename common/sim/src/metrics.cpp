#include "swarmloc/sim/metrics.hpp"

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>

#include "swarmloc/estimators/crlb.hpp"

namespace swarmloc::sim {

ErrorStats score(const std::vector<Vec2>& truth, const std::vector<bool>& is_anchor,
                 const std::vector<std::optional<estimators::Estimate>>& estimates) {
  ErrorStats stats;
  double squared = 0.0;
  double sum = 0.0;
  double nees_sum = 0.0;
  int nees_count = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    if (is_anchor[i]) continue;
    if (!estimates[i]) {
      ++stats.missing;
      continue;
    }
    const Vec2 error = estimates[i]->mean_m - truth[i];
    const double norm = error.norm();
    if (!std::isfinite(norm)) {
      ++stats.missing;
      continue;
    }
    squared += norm * norm;
    sum += norm;
    stats.max_error_m = std::max(stats.max_error_m, norm);
    ++stats.scored;
    const Mat2& cov = estimates[i]->covariance;
    if (estimates[i]->valid && cov.allFinite() && cov.determinant() > 0.0) {
      nees_sum += error.dot(cov.ldlt().solve(error));
      ++nees_count;
    }
  }
  if (stats.scored > 0) {
    stats.rmse_m = std::sqrt(squared / stats.scored);
    stats.mean_error_m = sum / stats.scored;
  }
  stats.nees = nees_count > 0 ? nees_sum / nees_count : std::numeric_limits<double>::quiet_NaN();
  return stats;
}

double RangeCrlb::accumulated_rmse_m(double snapshots) const {
  return snapshots > 0.0 ? single_snapshot_rmse_m / std::sqrt(snapshots) : single_snapshot_rmse_m;
}

RangeCrlb range_crlb(const World& world, double range_std_m) {
  std::vector<estimators::RangeObservation> observations;
  for (int i = 0; i < world.size(); ++i) {
    for (AgentId j : world.neighbours[static_cast<std::size_t>(i)]) {
      observations.push_back({i, j, range_std_m});
    }
  }
  const auto result = estimators::range_network_crlb(world.truth, world.is_anchor, observations, 1.0);
  RangeCrlb crlb;
  crlb.single_snapshot_rmse_m = result.network_rmse_m;
  crlb.per_agent_single_rmse_m = result.per_agent_rmse_m;
  crlb.localizable = result.localizable;
  return crlb;
}

}  // namespace swarmloc::sim
