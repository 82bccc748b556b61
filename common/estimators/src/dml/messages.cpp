// dml's means as belief propagation's (docs/algorithms.md §9.2): the messages an agent solves against, and
// the cavities it sends its neighbours.
#include <vector>

#include "dml/cavity.hpp"
#include "dml/rank_one_message.hpp"
#include "swarmloc/estimators/dml/dml.hpp"

namespace swarmloc::estimators {
namespace {

using rank_one::kShortestDistanceM;
// 1 − s·q at or below this: the belief holds little besides the message, and the cavity's mean would
// amplify any change in it more than 20-fold (3-D worlds at a 15 m radius diverged at 1e-3).
constexpr double kCavityRemainingFloor = 0.05;

}  // namespace

template <int D>
std::vector<typename DmlT<D>::Reference> DmlT<D>::message_references() const {
  std::vector<Reference> refs;
  for (const auto& [id, edge] : edges_) {
    if (!edge.usable() || !(edge.message_scale > 0.0)) continue;
    // Linearized where both ends linearize the range, at the two published means: the distance to the
    // neighbour's mean is the range plus how far its cavity lies toward this agent.
    const Vec offset = x_ - edge.mean_m;
    const double toward_m = edge.cavity && offset.norm() >= kShortestDistanceM
                                ? offset.normalized().dot(edge.cavity->offset_m)
                                : 0.0;
    refs.push_back({id, edge.mean_m, edge.mean_range_m() + toward_m, edge.message_scale});
  }
  return refs;
}

template <int D>
std::vector<EdgeCavity> DmlT<D>::cavities() const {
  std::vector<EdgeCavity> cavities;
  if (!localized_ || exact_anchor() || !dml_dimension::positive_definite_d<D>(information_)) return cavities;
  const Mat covariance = information_.inverse();
  for (const auto& ref : message_references()) {
    if (cavities.size() == StateMessage::kMaxCavities) break;
    const Vec offset = x_ - ref.position_m;
    if (offset.norm() < kShortestDistanceM) continue;
    const Vec a = offset.normalized();
    const auto along = dml_cavity::along_edge<D>(covariance, a, ref.information);
    if (!(along.remaining > kCavityRemainingFloor)) continue;  // the belief is (almost) all this message
    // x_ minimizes the message terms; without this one, a Newton step from x_ on the others
    // (Sherman–Morrison).
    const double residual = ref.mean_range_m - offset.norm();
    const Vec shift = -(covariance * a) * (ref.information * residual / along.remaining);
    EdgeCavity cavity;
    cavity.peer = ref.id;
    cavity.offset_m = shift.template head<2>();
    if constexpr (D == 3) cavity.offset_z_m = shift(2);
    cavity.variance_m2 = along.variance / along.remaining;
    cavities.push_back(cavity);
  }
  return cavities;
}

template std::vector<DmlT<2>::Reference> DmlT<2>::message_references() const;
template std::vector<DmlT<3>::Reference> DmlT<3>::message_references() const;
template std::vector<EdgeCavity> DmlT<2>::cavities() const;
template std::vector<EdgeCavity> DmlT<3>::cavities() const;

}  // namespace swarmloc::estimators
