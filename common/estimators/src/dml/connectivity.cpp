#include "swarmloc/estimators/dml/connectivity.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace swarmloc::estimators {

TwoHopPositions::TwoHopPositions(double radius_m)
    : radius_m_(radius_m), enabled_(std::isfinite(radius_m) && radius_m > 0.0) {}

int TwoHopPositions::absorb(AgentId self, const Vec2& sender_mean_m,
                            const std::vector<EdgeRangeSummary>& summaries) {
  if (!enabled_ || !sender_mean_m.allFinite()) return 0;
  int kept = 0;
  for (const auto& summary : summaries) {
    if (summary.peer == self || !summary.peer_mean_m.allFinite() || summary.peer_mean_m == sender_mean_m ||
        !(summary.information > 0.0) || !std::isfinite(summary.mean_range_m)) {
      continue;
    }
    // The same sender measured the edge and reports the peer's mean: the two must agree, and the peer is
    // one of its neighbours, so within the radius of it.
    const double distance = (summary.peer_mean_m - sender_mean_m).norm();
    if (std::abs(distance - summary.mean_range_m) > margin_m() || distance > radius_m_ + margin_m()) continue;
    positions_[summary.peer] = summary.peer_mean_m;
    ++kept;
  }
  return kept;
}

void RelayedRanges::absorb(AgentId self, AgentId sender, const Vec2& sender_mean_m,
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
    if (!summary.peer_mean_m.allFinite() || summary.peer_mean_m == sender_mean_m) {
      // No position of the peer: keep the range alone, unless a relay with the peer's position holds it.
      if (!placed) unplaced_[key] = {summary.mean_range_m, summary.information};
      continue;
    }
    if (!unplaced_.empty()) unplaced_.erase(key);
    const Entry fresh{sender, summary.peer, summary.peer_mean_m, summary.mean_range_m, summary.information};
    if (placed) {
      *at = fresh;
    } else {
      entries_.insert(at, fresh);
    }
  }
}

}  // namespace swarmloc::estimators
