// dml in 3-D: a multilateration whose references lie near one plane (docs/algorithms.md §9.9).
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include "dml/thresholds.hpp"
#include "swarmloc/estimators/dml/dml.hpp"

namespace swarmloc::estimators {

template <int D>
double DmlT<D>::fit_statistic(const Vec& x, const std::vector<Reference>& refs) const {
  double statistic = 0.0;
  for (const auto& ref : refs) {
    const Vec offset = x - ref.position_m;
    const Edge& edge = edges_.at(ref.id);
    const double along = offset.norm() > 0.0 && !(edge.anchor && edge.covariance.isZero())
                             ? offset.normalized().dot(edge.covariance * offset.normalized())
                             : 0.0;
    if (!std::isfinite(along)) continue;
    const double residual = ref.mean_range_m - offset.norm();
    statistic += residual * residual / (1.0 / ref.information + along);
  }
  return statistic;
}

template <int D>
std::optional<typename DmlT<D>::Vec> DmlT<D>::unless_mirrored(const Vec& solution,
                                                              const std::vector<Reference>& refs) const {
  // References near one plane leave a second minimum across it (exactly so with D of them) that fits their
  // ranges about as well: refined from the solution's reflection across their least-squares plane.
  Vec centre = Vec::Zero();
  for (const auto& ref : refs) centre += ref.position_m / static_cast<double>(refs.size());
  Mat scatter = Mat::Zero();
  for (const auto& ref : refs) scatter += (ref.position_m - centre) * (ref.position_m - centre).transpose();
  const Vec normal = Eigen::SelfAdjointEigenSolver<Mat>(scatter).eigenvectors().col(0);
  const Vec mirror = solve_position(solution - 2.0 * (solution - centre).dot(normal) * normal, refs);
  const double gap = fit_statistic(mirror, refs) - fit_statistic(solution, refs);
  const Vec& better = gap < 0.0 ? mirror : solution;
  double shortest_range_m = refs.front().mean_range_m;
  for (const auto& ref : refs) shortest_range_m = std::min(shortest_range_m, ref.mean_range_m);
  const double separation = (mirror - solution).norm();
  if (separation <= dml_thresholds::kMultilaterationSpreadFraction * shortest_range_m ||
      std::abs(gap) > dml_thresholds::mirror_gap())
    return better;  // one place, or the ranges tell the two apart
  if (const auto allowed = allowed_by_graph(solution, mirror)) return *allowed == 0 ? solution : mirror;
  // The guess tells them apart if they are far apart for its std and it allows the nearer one.
  const Vec guess = dml_dimension::position<D>(setup_.initial_guess_m, setup_.initial_altitude_m);
  const Vec& nearer = (solution - guess).norm() <= (mirror - guess).norm() ? solution : mirror;
  const double guess_variance = setup_.initial_guess_std_m * setup_.initial_guess_std_m;
  if (separation > dml_thresholds::kMirrorSeparationSigmas * setup_.initial_guess_std_m &&
      (nearer - guess).squaredNorm() <= dml_thresholds::guess_allowance() * guess_variance)
    return nearer;
  return std::nullopt;  // wait for a reference off the plane, the graph, or the local map
}

template double DmlT<2>::fit_statistic(const Vec2&, const std::vector<Reference>&) const;
template double DmlT<3>::fit_statistic(const Vec3&, const std::vector<Reference>&) const;
template std::optional<Vec2> DmlT<2>::unless_mirrored(const Vec2&, const std::vector<Reference>&) const;
template std::optional<Vec3> DmlT<3>::unless_mirrored(const Vec3&, const std::vector<Reference>&) const;

}  // namespace swarmloc::estimators
