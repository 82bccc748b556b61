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
    if (summary.peer == self || summary.peer == sender || !summary.peer_mean_m.allFinite() ||
        summary.peer_mean_m == sender_mean_m || !(summary.information > 0.0) ||
        !std::isfinite(summary.mean_range_m) || !(summary.mean_range_m >= 0.0)) {
      continue;
    }
    const auto at = std::lower_bound(entries_.begin(), entries_.end(), std::pair{sender, summary.peer},
                                     [](const Entry& entry, const std::pair<AgentId, AgentId>& key) {
                                       return std::pair{entry.via, entry.peer} < key;
                                     });
    const Entry fresh{sender, summary.peer, summary.peer_mean_m, summary.mean_range_m, summary.information};
    if (at != entries_.end() && at->via == sender && at->peer == summary.peer) {
      *at = fresh;
    } else {
      entries_.insert(at, fresh);
    }
  }
}

}  // namespace swarmloc::estimators
