#pragma once
// Cramér–Rao lower bound of a static range network (docs/algorithms.md §1.3). Anchors with exactly known
// positions are removed from θ; every other agent contributes a D-block: planar (D = 2) or 3-D networks.
#include <limits>
#include <vector>

#include "swarmloc/core/types.hpp"

namespace swarmloc::estimators {

/// One range measurement per snapshot: agent `a` measured its distance to agent `b` (variance std²).
/// In the IEIF both a→b and b→a are measured, so an undirected link appears twice
/// (see mutual_range_observations).
struct RangeObservation {
  AgentId a = 0;
  AgentId b = 0;
  double std_m = 0.0;
};

/// One absolute (GPS) fix of `agent` per snapshot with covariance `covariance` (§1.3: adds R⁻¹ to (i,i)).
template <int D>
struct AbsoluteObservationOf {
  AgentId agent = 0;
  Eigen::Matrix<double, D, D> covariance = Eigen::Matrix<double, D, D>::Identity();
};
using AbsoluteObservation = AbsoluteObservationOf<2>;
using AbsoluteObservation3 = AbsoluteObservationOf<3>;

/// A static network: true positions, which agents are exactly known, and the measurements made in
/// one snapshot. D = 2 (planar) or 3.
template <int D>
struct RangeNetworkOf {
  std::vector<Eigen::Matrix<double, D, 1>> truth;
  std::vector<bool> is_anchor;
  std::vector<RangeObservation> ranges;
  std::vector<AbsoluteObservationOf<D>> absolute;
};
using RangeNetwork = RangeNetworkOf<2>;
using RangeNetwork3 = RangeNetworkOf<3>;

template <int D>
struct CrlbResultOf {
  /// Per agent (indexed like `truth`): the D×D block [J⁻¹]_ii; zero for anchors, +inf entries for
  /// an agent that is not localizable.
  std::vector<Eigen::Matrix<double, D, D>> per_agent;
  /// Per agent sqrt(tr([J⁻¹]_ii)) (m); 0 for anchors, +inf if not localizable.
  std::vector<double> per_agent_rmse_m;
  /// sqrt(tr(CRB)/n_u) over non-anchor agents (m), D coordinates each; +inf unless every non-anchor is
  /// localizable.
  double network_rmse_m = std::numeric_limits<double>::infinity();
  /// True if every non-anchor agent has a finite bound.
  bool localizable = false;
};
using CrlbResult = CrlbResultOf<2>;
using CrlbResult3 = CrlbResultOf<3>;

/// Fisher information over the non-anchor agents (D·n_u × D·n_u, agents in index order):
/// J = J_prior + snapshots·J_1, J_1 = Σ_m H_mᵀ R_m⁻¹ H_m at the true positions (§1.3).
/// `prior_information`, if given, holds one D×D information block per agent (anchors ignored).
/// Throws std::invalid_argument on inconsistent sizes, ids out of range or std_m ≤ 0.
MatX range_network_fisher(const RangeNetwork& network, double snapshots = 1.0,
                          const std::vector<Mat2>* prior_information = nullptr);
MatX range_network_fisher(const RangeNetwork3& network, double snapshots = 1.0,
                          const std::vector<Mat3>* prior_information = nullptr);

/// CRB = J⁻¹ via a dense Cholesky factorization. If J is singular (non-rigid graph, anchor-free
/// gauge freedom), agents touched by its null space get +inf and the others the block of J⁺.
CrlbResult network_crlb(const RangeNetwork& network, double snapshots = 1.0,
                        const std::vector<Mat2>* prior_information = nullptr);
CrlbResult3 network_crlb(const RangeNetwork3& network, double snapshots = 1.0,
                         const std::vector<Mat3>* prior_information = nullptr);

/// Convenience form: ranges only. `snapshots` = t repeated independent snapshots (J_t = J_prior + t·J_1).
CrlbResult range_network_crlb(const std::vector<Vec2>& truth, const std::vector<bool>& is_anchor,
                              const std::vector<RangeObservation>& per_snapshot, double snapshots = 1.0,
                              const std::vector<Mat2>* prior_information = nullptr);

/// Both directions i→j and j→i for every pair with ‖x_i − x_j‖ ≤ radius_m, except anchor–anchor
/// pairs (the IEIF measuring pattern, §3.1).
std::vector<RangeObservation> mutual_range_observations(
    const std::vector<Vec2>& truth, const std::vector<bool>& is_anchor, double std_m,
    double radius_m = std::numeric_limits<double>::infinity());

}  // namespace swarmloc::estimators
