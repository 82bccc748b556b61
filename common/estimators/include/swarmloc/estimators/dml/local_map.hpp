#pragma once
// dml's start for an agent the multilateration wave does not reach (docs/algorithms.md §9.4, "Local
// maps"): a pocket of agents that is rigid only together. The agent draws a map of its neighbourhood from
// its own ranges and the ranges its neighbours relay (classical multidimensional scaling on the shortest
// path completion of the distances, after Shang and Ruml's MDS-MAP(P)), fits it to the localized agents in
// it, refines it on the ranges, and starts from its own place in it when the map fits the data.
#include <optional>
#include <vector>

#include "swarmloc/estimators/dml/dimension.hpp"

namespace swarmloc::estimators::local_map {

/// An agent in the map: one whose position is known (a localized neighbour, or one a neighbour relays) or
/// one to place. Node 0 is the agent that draws the map.
template <int D>
struct NodeT {
  bool known = false;
  VecD<D> position_m = VecD<D>::Zero();  // known nodes: the position; the others: a guess, a start of the fit
};
using Node = NodeT<2>;
/// A measured range between two nodes (indices), with the information of its draws (Σ 1/σ²).
struct Range {
  int first = 0;
  int second = 0;
  double range_m = 0.0;
  double information = 0.0;
};

template <int D>
struct PlacementT {
  VecD<D> position_m;                    // node 0's place in the best map
  std::optional<VecD<D>> alternative_m;  // its place in another map that fits the ranges too (a mirror image)
};
using Placement = PlacementT<2>;

/// Node 0's place, or nothing if the map does not fix it. Nodes to place that keep fewer than D + 1 ranges
/// are left out (they could flip). Then node 0 must be in the map, the map must hold D known nodes (with
/// D, every map has a mirror image across the line, or plane, through them), reach every node by its
/// ranges, have more ranges than coordinates to fit, fit them within a χ² test at `false_alarm`, and fix
/// node 0 to a standard deviation of at most `max_std_m`.
template <int D>
/// `agent_starts`: more places to refine a map from, node 0 there and the others where they are (3-D: the
/// mirror pair of node 0's references, which the whole map's scaling and reflection need not reach).
/// `mirror_gap`: another map within this much of the best one's cost is a mirror image too, even if it fails
/// the test (3-D: held nodes' errors beyond their covariance can tip the test toward the wrong side).
std::optional<PlacementT<D>> place(const std::vector<NodeT<D>>& nodes, const std::vector<Range>& ranges,
                                   double false_alarm, double max_std_m,
                                   const std::vector<VecD<D>>& agent_starts = {}, double mirror_gap = 0.0);

/// Node 0's covariance in the map linearized where the nodes are (the inverse of the ranges' Fisher
/// information over the nodes to place, the known nodes held), or nothing if the map does not fix it.
/// Nodes to place held by fewer than D ranges are left out (they turn freely and inform no other node).
template <int D>
std::optional<MatD<D>> covariance_at(const std::vector<NodeT<D>>& nodes, const std::vector<Range>& ranges);

extern template std::optional<PlacementT<2>> place(const std::vector<NodeT<2>>&, const std::vector<Range>&,
                                                   double, double, const std::vector<Vec2>&, double);
extern template std::optional<PlacementT<3>> place(const std::vector<NodeT<3>>&, const std::vector<Range>&,
                                                   double, double, const std::vector<Vec3>&, double);
extern template std::optional<Mat2> covariance_at(const std::vector<NodeT<2>>&, const std::vector<Range>&);
extern template std::optional<Mat3> covariance_at(const std::vector<NodeT<3>>&, const std::vector<Range>&);

}  // namespace swarmloc::estimators::local_map
