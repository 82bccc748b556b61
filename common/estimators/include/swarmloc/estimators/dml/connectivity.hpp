#pragma once
// Negative connectivity for dml (docs/algorithms.md §9.4): links exist exactly between agents within the
// communication radius, so an agent that does not hear agent m is farther than the radius from it. The
// positions of such agents reach it through its neighbours' edge summaries (each carries the peer's mean).
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <utility>
#include <vector>

#include "swarmloc/estimators/dml/dimension.hpp"
#include "swarmloc/estimators/messages.hpp"

namespace swarmloc::estimators {

template <int D>
class TwoHopPositionsT {
 public:
  /// radius_m: the communication radius (+inf or not positive: unknown, nothing is ever kept).
  explicit TwoHopPositionsT(double radius_m);

  [[nodiscard]] bool enabled() const { return enabled_; }
  /// Keeps the peer means a localized neighbour relays (its edge summaries). Skips entries about `self`,
  /// entries marked unknown (the sender's own mean) and garbled ones: a peer mean that disagrees with the
  /// sender's own range to that peer, or lies beyond the radius from the sender. Returns the entries kept.
  int absorb(AgentId self, const VecD<D>& sender_mean_m, const std::vector<EdgeRangeSummary>& summaries);
  /// How far `x` lies inside the radius of the nearest known agent that `heard` says this agent does not
  /// hear (> 0: x contradicts the graph); -inf if none is known.
  template <typename Heard>
  [[nodiscard]] double penetration(const VecD<D>& x, const Heard& heard) const {
    double worst = -std::numeric_limits<double>::infinity();
    for (const auto& [id, position] : positions_) {
      if (!heard(id)) worst = std::max(worst, radius_m_ - (x - position).norm());
    }
    return worst;
  }
  /// The margin a penetration must exceed to count: estimates are centimetres off, a flip metres.
  [[nodiscard]] double margin_m() const { return kMarginFraction * radius_m_; }
  [[nodiscard]] std::size_t size() const { return positions_.size(); }

  static constexpr double kMarginFraction = 0.05;

 private:
  double radius_m_;
  bool enabled_;
  // Newest relayed mean per agent, sorted by id: a flat vector, not a map, keeps an agent's dozens of
  // entries in one block (1000 agents in one process: docs/scale.md).
  std::vector<std::pair<AgentId, VecD<D>>> positions_;
};

/// Ranges through a neighbour (docs/algorithms.md §9.4): neighbour c measured r_cm to agent m and relays
/// m's mean p_m, so with this agent's own range r_c to c the triangle inequality bounds its distance to m:
/// |r_c − r_cm| ≤ ‖x − p_m‖ ≤ r_c + r_cm. Kept from every neighbour, localized or not (c's own position
/// plays no part).
template <int D>
class RelayedRangesT {
 public:
  /// Keeps `sender`'s summaries: with the peer's mean where they carry one (not the sender's own mean, its
  /// "unknown"), else the range alone (for local maps only).
  void absorb(AgentId self, AgentId sender, const VecD<D>& sender_mean_m,
              const std::vector<EdgeRangeSummary>& summaries);
  /// Calls visit(p, q, information) for what agent ids[p] relayed of its own draws of its range to
  /// ids[q]; `ids` ascending.
  template <typename Visit>
  void for_each_information_among(const std::vector<AgentId>& ids, const Visit& visit) const {
    auto entry = entries_.begin();
    for (std::size_t p = 0; p < ids.size(); ++p) {
      entry = std::lower_bound(entry, entries_.end(), ids[p],
                               [](const Entry& e, AgentId via) { return e.via < via; });
      std::size_t q = 0;
      for (; entry != entries_.end() && entry->via == ids[p]; ++entry) {
        while (q < ids.size() && ids[q] < entry->peer) ++q;  // both ascending: one merge pass
        if (q < ids.size() && ids[q] == entry->peer) visit(p, q, entry->information);
      }
    }
  }
  /// Calls visit(via, peer, range_m, information, peer_mean) for every range a neighbour relayed, with
  /// peer_mean nullptr where the neighbour did not know the peer's position (dml's local maps, §9.4).
  template <typename Visit>
  void for_each_range(const Visit& visit) const {
    for (const auto& entry : entries_)
      visit(entry.via, entry.peer, entry.range_m, entry.information, &entry.peer_mean_m);
    for (const auto& [key, entry] : unplaced_)
      visit(key.first, key.second, entry.range_m, entry.information, static_cast<const VecD<D>*>(nullptr));
  }
  /// The worst violation at `x` of the bounds through the neighbours `own_range` gives a range to
  /// (> 0: x contradicts the data by that much); -inf if no bound is known. `own_range(c)` returns this
  /// agent's mean range to c, or a negative value if it has none.
  template <typename OwnRange>
  [[nodiscard]] double violation(const VecD<D>& x, const OwnRange& own_range) const {
    double worst = -std::numeric_limits<double>::infinity();
    double r_via = -1.0;
    for (std::size_t k = 0; k < entries_.size(); ++k) {
      const Entry& entry = entries_[k];
      if (k == 0 || entry.via != entries_[k - 1].via) r_via = own_range(entry.via);  // sorted by via
      if (!(r_via >= 0.0)) continue;
      const double distance = (x - entry.peer_mean_m).norm();
      worst =
          std::max({worst, distance - (r_via + entry.range_m), std::abs(r_via - entry.range_m) - distance});
    }
    return worst;
  }

 private:
  struct Entry {
    AgentId via;
    AgentId peer;
    VecD<D> peer_mean_m;
    double range_m;
    double information;
  };
  struct Unplaced {
    double range_m;
    double information;
  };
  using Key = std::pair<AgentId, AgentId>;
  std::vector<Entry> entries_;        // newest per (via, peer), sorted by (via, peer): scanned every step
  std::map<Key, Unplaced> unplaced_;  // ranges to peers the neighbour had no position of (not in entries_)
};

extern template class TwoHopPositionsT<2>;
extern template class TwoHopPositionsT<3>;
extern template class RelayedRangesT<2>;
extern template class RelayedRangesT<3>;
using TwoHopPositions = TwoHopPositionsT<2>;
using RelayedRanges = RelayedRangesT<2>;

}  // namespace swarmloc::estimators
