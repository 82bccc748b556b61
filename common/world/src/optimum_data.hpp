#pragma once
// The parts of the run's optimum (optimum.cpp) that its static and moving data share (docs/algorithms.md
// §1.3.2): which draws the algorithm's data hold, their sufficient statistics, and the scoring of a solution.
// Internal to the world library.
#include <memory>
#include <utility>
#include <vector>

#include "swarmloc/world/optimum.hpp"

namespace swarmloc::world {

/// What the algorithm's data hold (config::BoundSpec, docs/algorithms.md §1.3.1) and the world's static
/// facts. Not in the anonymous namespace: OptimumAccumulator::Data, which has external linkage, holds one.
struct OptimumSelection {
  config::RangeDraws draws = config::RangeDraws::kAllDraws;
  bool anchors_in_state = false;  ///< anchors are unknowns with fixes (else their positions are known)
  bool shared = false;            ///< both ends hold one draw: it counts once
  std::vector<bool> is_anchor;
  std::vector<double> altitude;                    ///< a 3-D world's true z per agent (empty: planar)
  std::vector<std::vector<AgentId>> neighbours;    ///< the step-0 graph (sorted)
  std::vector<std::vector<int>> edge_of;           ///< parallel to neighbours: the undirected edge's index
  std::vector<std::pair<AgentId, AgentId>> edges;  ///< (lo, hi)

  [[nodiscard]] bool anchor(AgentId i) const { return is_anchor[static_cast<std::size_t>(i)]; }

  /// Whether agent i's draw of the range to j is in the data (snapshot_network's rule, with the values).
  [[nodiscard]] bool uses(AgentId i, AgentId j) const {
    switch (draws) {
      case config::RangeDraws::kOnePerEdge:
        return i < j;  // the fusion centre's: the lower id's draw (centralized_measurements)
      case config::RangeDraws::kOwnDraws:
        return !anchor(i) && (!shared || i < j || anchor(j));
      case config::RangeDraws::kAllDraws:
        break;
    }
    return !shared || i < j;
  }

  /// The undirected edge i–j of the step-0 graph, or −1.
  [[nodiscard]] int edge(AgentId i, AgentId j) const {
    const auto& list = neighbours[static_cast<std::size_t>(i)];
    const auto it = std::lower_bound(list.begin(), list.end(), j);
    if (it == list.end() || *it != j) return -1;
    return edge_of[static_cast<std::size_t>(i)][static_cast<std::size_t>(it - list.begin())];
  }
};

namespace optimum_parts {

/// Σ 1/σ² and Σ r/σ² of an edge's draws: their ML is that of one draw of the weighted mean.
struct EdgeStat {
  double information = 0.0;
  double weighted = 0.0;
};

/// Σ C⁻¹ and Σ C⁻¹ y of an anchor's fixes; in a 3-D world also Σ 1/σ_z² and Σ z/σ_z² of their z (a fix's z
/// has covariance(0, 0)'s variance, independent of x and y: AbsoluteFix).
struct FixStat {
  Mat2 information = Mat2::Zero();
  Vec2 weighted = Vec2::Zero();
  double z_information = 0.0;
  double z_weighted = 0.0;
};

/// Adds the selected range draws of one step's batches into `stats` (indexed by edge).
void add_ranges(const OptimumSelection& sel, const std::vector<estimators::MeasurementBatch>& batches,
                std::vector<EdgeStat>& stats);
/// Adds the anchors' fixes of one step's batches into `fixes` (indexed by agent), if anchors are unknowns.
void add_fixes(const OptimumSelection& sel, const std::vector<estimators::MeasurementBatch>& batches,
               std::vector<FixStat>& fixes);
/// Whether `fix` holds information on every one of the D coordinates.
template <int D>
bool informs(const FixStat& fix) {
  return fix.information.determinant() > 0.0 && (D == 2 || fix.z_information > 0.0);
}
/// The fixes of one anchor as one factor on its block `a`: x_a ~ N(mean of the fixes, (Σ C⁻¹)⁻¹).
template <int D>
OptimumLinearFactorOf<D> fix_factor(int a, const FixStat& fix) {
  if constexpr (D == 2) {
    return {a, -1, fix.information.ldlt().solve(fix.weighted), fix.information};
  } else {
    Mat3 information = Mat3::Zero();
    information.topLeftCorner<2, 2>() = fix.information;
    information(2, 2) = fix.z_information;
    return {a, -1, join(fix.information.ldlt().solve(fix.weighted), fix.z_weighted / fix.z_information),
            information};
  }
}
/// The optimum of `solution` at `step`: agent i at its block block[i] (−1: a known anchor, at its truth), its
/// z in 3-D (a known anchor's: truth_z), scored against `truth` and `truth_z`.
template <int D>
OptimumEstimate estimate_of(std::int64_t step, const OptimumSelection& sel, const std::vector<Vec2>& truth,
                            const std::vector<double>& truth_z, const std::vector<int>& block,
                            const OptimumSolutionOf<D>& solution);
/// RMSE and mean NEES of `estimate` over the world's non-anchor agents (in space if it has altitudes).
OptimumPoint score_point(std::int64_t step, const OptimumSelection& sel, const std::vector<Vec2>& truth,
                         const OptimumEstimate& estimate, bool singular, bool covariance);

/// An agent's point in the optimum's D dimensions: its planar part, with its z in 3-D.
template <int D>
Eigen::Matrix<double, D, 1> optimum_point_of(const Vec2& planar, const std::vector<double>& z,
                                             std::size_t i) {
  if constexpr (D == 2) {
    return planar;
  } else {
    return join(planar, z[i]);
  }
}

}  // namespace optimum_parts

// ---- The data, static or moving ----

class OptimumAccumulator::Data {
 public:
  explicit Data(OptimumSelection selection) : sel_(std::move(selection)) {}
  virtual ~Data() = default;
  Data(const Data&) = delete;
  Data& operator=(const Data&) = delete;
  Data(Data&&) = delete;
  Data& operator=(Data&&) = delete;
  /// `altitude`: a 3-D world's true z per agent at the step (empty in a planar one).
  virtual void observe(std::int64_t step, const std::vector<Vec2>& truth, const std::vector<double>& altitude,
                       const std::vector<estimators::MeasurementBatch>& batches) = 0;
  /// Keeps the data through `step` (the step just observed) for a later solve.
  virtual void checkpoint(std::int64_t step) = 0;
  /// The optimum of the data through `step` (a kept checkpoint or the last observed step); `estimates` (with
  /// their z in a 3-D world): a second start (static truth only).
  [[nodiscard]] virtual OptimumEstimate solve(std::int64_t step, const std::vector<Vec2>* estimates,
                                              const std::vector<double>* estimate_z) const = 0;
  /// Drops what was kept for `step`'s checkpoint.
  virtual void release(std::int64_t /*step*/) {}

 protected:
  OptimumSelection sel_;
};

namespace optimum_parts {

/// Moving truth: every step's data, and the MAP of the trajectory up to a step (optimum_moving.cpp).
std::unique_ptr<OptimumAccumulator::Data> make_moving_data(OptimumSelection selection, const World& world,
                                                           const config::Scenario& s);

}  // namespace optimum_parts
}  // namespace swarmloc::world
