#pragma once
// Negative connectivity for dml (docs/algorithms.md §9.4): links exist exactly between agents within the
// communication radius, so an agent that does not hear agent m is farther than the radius from it. The
// positions of such agents reach it through its neighbours' edge summaries (each carries the peer's mean).
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <vector>

#include "swarmloc/estimators/messages.hpp"

namespace swarmloc::estimators {

class TwoHopPositions {
 public:
  /// radius_m: the communication radius (+inf or not positive: unknown, nothing is ever kept).
  explicit TwoHopPositions(double radius_m);

  [[nodiscard]] bool enabled() const { return enabled_; }
  /// Keeps the peer means a localized neighbour relays (its edge summaries). Skips entries about `self`,
  /// entries marked unknown (the sender's own mean) and garbled ones: a peer mean that disagrees with the
  /// sender's own range to that peer, or lies beyond the radius from the sender. Returns the entries kept.
  int absorb(AgentId self, const Vec2& sender_mean_m, const std::vector<EdgeRangeSummary>& summaries);
  /// How far `x` lies inside the radius of the nearest known agent that `heard` says this agent does not
  /// hear (> 0: x contradicts the graph); -inf if none is known.
  template <typename Heard>
  [[nodiscard]] double penetration(const Vec2& x, const Heard& heard) const {
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
  std::map<AgentId, Vec2> positions_;  // newest relayed mean per agent
};

}  // namespace swarmloc::estimators
