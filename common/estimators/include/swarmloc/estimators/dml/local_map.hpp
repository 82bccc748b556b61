#pragma once
// dml's start for an agent the multilateration wave does not reach (docs/algorithms.md §9.4, "Local
// maps"): a pocket of agents that is rigid only together. The agent draws a map of its neighbourhood from
// its own ranges and the ranges its neighbours relay (classical multidimensional scaling on the shortest
// path completion of the distances, after Shang and Ruml's MDS-MAP(P)), fits it to the localized agents in
// it, refines it on the ranges, and starts from its own place in it when the map fits the data.
#include <optional>
#include <vector>

#include "swarmloc/core/types.hpp"

namespace swarmloc::estimators::local_map {

/// An agent in the map: one whose position is known (a localized neighbour, or one a neighbour relays) or
/// one to place. Node 0 is the agent that draws the map.
struct Node {
  bool known = false;
  Vec2 position_m = Vec2::Zero();  // known nodes: the position; the others: a guess, one start of the fit
};
/// A measured range between two nodes (indices), with the information of its draws (Σ 1/σ²).
struct Range {
  int first = 0;
  int second = 0;
  double range_m = 0.0;
  double information = 0.0;
};

struct Placement {
  Vec2 position_m;                    // node 0's place in the best map
  std::optional<Vec2> alternative_m;  // its place in another map that fits the ranges too (a mirror image)
};

/// Node 0's place, or nothing if the map does not fix it. Nodes to place that keep fewer than three ranges
/// are left out (they could flip). Then node 0 must be in the map, the map must hold two known nodes (with
/// two, every map has a mirror image across the line through them), reach every node by its ranges, have
/// more ranges than coordinates to fit, fit them within a χ² test at `false_alarm`, and fix node 0 to a
/// standard deviation of at most `max_std_m`.
std::optional<Placement> place(const std::vector<Node>& nodes, const std::vector<Range>& ranges,
                               double false_alarm, double max_std_m);

/// Node 0's covariance in the map linearized where the nodes are (the inverse of the ranges' Fisher
/// information over the nodes to place, the known nodes held), or nothing if the map does not fix it.
/// Nodes to place held by a single range are left out (they inform no other node).
std::optional<Mat2> covariance_at(const std::vector<Node>& nodes, const std::vector<Range>& ranges);

}  // namespace swarmloc::estimators::local_map
