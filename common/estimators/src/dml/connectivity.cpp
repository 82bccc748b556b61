#include "swarmloc/estimators/dml/connectivity.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace swarmloc::estimators {

template <int D>
TwoHopPositionsT<D>::TwoHopPositionsT(double radius_m)
    : radius_m_(radius_m), enabled_(std::isfinite(radius_m) && radius_m > 0.0) {}

template <int D>
int TwoHopPositionsT<D>::absorb(AgentId self, const VecD<D>& sender_mean_m,
                                const std::vector<EdgeRangeSummary>& summaries) {
  if (!enabled_ || !sender_mean_m.allFinite()) return 0;
  int kept = 0;
  for (const auto& summary : summaries) {
    const VecD<D> peer_mean_m = dml_dimension::peer_position<D>(summary);
    if (summary.peer == self || !peer_mean_m.allFinite() || peer_mean_m == sender_mean_m ||
        !(summary.information > 0.0) || !std::isfinite(summary.mean_range_m)) {
      continue;
    }
    // The same sender measured the edge and reports the peer's mean: the two must agree, and the peer is
    // one of its neighbours, so within the radius of it.
    const double distance = (peer_mean_m - sender_mean_m).norm();
    if (std::abs(distance - summary.mean_range_m) > margin_m() || distance > radius_m_ + margin_m()) continue;
    const auto at = std::lower_bound(positions_.begin(), positions_.end(), summary.peer,
                                     [](const auto& entry, AgentId id) { return entry.first < id; });
    if (at != positions_.end() && at->first == summary.peer) {
      at->second = peer_mean_m;
    } else {
      positions_.insert(at, {summary.peer, peer_mean_m});
    }
    ++kept;
  }
  return kept;
}

template <int D>
void RelayedRangesT<D>::absorb(AgentId self, AgentId sender, const VecD<D>& sender_mean_m,
                               const std::vector<EdgeRangeSummary>& summaries) {
  for (const auto& summary : summaries) {
    if (summary.peer == self || summary.peer == sender || !(summary.information > 0.0) ||
        !std::isfinite(summary.mean_range_m) || !(summary.mean_range_m >= 0.0)) {
      continue;
    }
    const Key key{sender, summary.peer};
    const auto at =
        std::lower_bound(entries_.begin(), entries_.end(), key, [](const Entry& entry, const Key& k) {
          return Key{entry.via, entry.peer} < k;
        });
    const bool placed = at != entries_.end() && at->via == sender && at->peer == summary.peer;
    const VecD<D> peer_mean_m = dml_dimension::peer_position<D>(summary);
    if (!peer_mean_m.allFinite() || peer_mean_m == sender_mean_m) {
      // No position of the peer: keep the range alone, unless a relay with the peer's position holds it.
      if (!placed) unplaced_[key] = {summary.mean_range_m, summary.information};
      continue;
    }
    if (!unplaced_.empty()) unplaced_.erase(key);
    const Entry fresh{sender, summary.peer, peer_mean_m, summary.mean_range_m, summary.information};
    if (placed) {
      *at = fresh;
    } else {
      entries_.insert(at, fresh);
    }
  }
}

template class TwoHopPositionsT<2>;
template class TwoHopPositionsT<3>;
template class RelayedRangesT<2>;
template class RelayedRangesT<3>;

}  // namespace swarmloc::estimators
