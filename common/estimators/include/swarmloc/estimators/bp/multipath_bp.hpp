#pragma once
// Cooperative Gaussian belief propagation with multipath range + DOA (Leng et al. Algorithm 1,
// docs/algorithms.md §5), and the pairwise (non-cooperative) baseline of §5.4.
#include <map>
#include <optional>
#include <string_view>
#include <vector>

#include "swarmloc/estimators/bp/params.hpp"
#include "swarmloc/estimators/estimator.hpp"

namespace swarmloc::estimators::bp {

/// The paths between this node (S_i) and one peer (S_j): G_ji (R×2, rows g(θ_ij, θ_ji)ᵀ [D-1]) and d_ji.
struct PathSet {
  MatX G;
  VecX d;
};

/// Builds G_ji, d_ji from the MultipathMeasurements with `peer` (sorted by path_index).
PathSet path_set(const std::vector<MultipathMeasurement>& paths, AgentId peer, double los_threshold = 1e-3);

struct Gaussian2 {
  Vec2 mean = Vec2::Zero();
  Mat2 covariance = Mat2::Zero();
};

/// Each path's noise variance v_r. With exact angles it is σ². With angle errors of variance σ_θ² at both
/// ends (not in Leng et al.), eq. (1)'s prediction moves too: ∂d/∂θ_ij = a cot(Δ/2) and ∂d/∂θ_ji = b
/// cot(Δ/2), where Δ = θ_ji − θ_ij, a and b are the scatter point's distances from S_j and S_i, and cot²(Δ/2)
/// = ‖g‖² − 1. Hence v_r = σ² + σ_θ² (‖g_r‖² − 1)(a² + b²), with a = b = d_r/2 since the split of the path is
/// unknown (it under-states a² + b² by at most a factor 2, when one end is at the wall). LOS paths (‖g‖ = 1)
/// keep σ². Nearly parallel rays make ‖g‖ large: the angles then dominate.
VecX path_variances(const PathSet& paths, const MultipathBpParams& params);

/// Pairwise baseline step (§5.4, eq. (2)): s_i = s_j + G_ji†d_ji with covariance P_j + σ²(G_jiᵀG_ji)⁻¹;
/// with angle errors (params.doa_variance_rad2 > 0) the weighted least-squares form with the paths'
/// variances V: s_j + (GᵀV⁻¹G)⁻¹GᵀV⁻¹d and P_j + (GᵀV⁻¹G)⁻¹. nullopt if G_ji has rank < 2.
std::optional<Gaussian2> pairwise_from_parent(const Gaussian2& parent, const PathSet& paths,
                                              const MultipathBpParams& params);

/// Message of one neighbour in information form: (W_ji⁻¹, W_ji⁻¹ ν_ji) (§5.2 numerically safe form).
struct InformationPair {
  Mat2 information = Mat2::Zero();
  Vec2 info_vec = Vec2::Zero();
};
/// What one peer's paths give before any belief arrives, computed once per path set (not per iteration):
/// the paths' variances and, when G_ji has full column rank, A_ji = G_jiᵀV⁻¹G_ji and the relative position
/// (G_jiᵀV⁻¹G_ji)⁻¹G_jiᵀV⁻¹d_ji (G†d with V = σ²I).
struct LinkModel {
  PathSet paths;
  VecX variances;
  bool full_rank = false;
  Mat2 A = Mat2::Zero();
  Vec2 relative = Vec2::Zero();
};
LinkModel link_model(PathSet paths, const MultipathBpParams& params);

/// Anchor neighbour (P_j = 0): A_ji = G_jiᵀG_ji/σ²; otherwise A − A(A + Λ_j)⁻¹A; the general form
/// C = σ²I + G P_j Gᵀ when rank(G) < 2. With angle errors σ²I becomes V = diag(path_variances()) and
/// A_ji = G_jiᵀV⁻¹G_ji. nullopt if Λ_j is not PD (the neighbour carries no information).
std::optional<InformationPair> neighbour_message(const LinkModel& link, const Vec2& mean_j,
                                                 const Mat2& info_j, bool anchor_j,
                                                 const MultipathBpParams& params);
/// The same from the raw paths (builds their LinkModel first).
std::optional<InformationPair> neighbour_message(const PathSet& paths, const Vec2& mean_j, const Mat2& info_j,
                                                 bool anchor_j, const MultipathBpParams& params);

/// The paths of one link (i, j) as seen from S_i: G_ji and d_ji.
struct LinkPaths {
  AgentId i = 0;
  AgentId j = 0;
  PathSet paths;
};

/// Centralized baseline (not in Leng et al.): weighted least squares on every path length of eq. (1) at once,
/// d_ji − G_ji(s_i − s_j) with weights V⁻¹ (V = diag(path_variances())), over the nodes whose
/// `anchor_positions` entry is empty; anchors are fixed. It is what exact GaBP's means converge to. Returns
/// every node's mean and covariance (anchors: their position, zero covariance), or nullopt if the links do
/// not determine every node (the normal matrix is not PD).
std::optional<std::vector<Gaussian2>> centralized_from_paths(
    const std::vector<std::optional<Vec2>>& anchor_positions, const std::vector<LinkPaths>& links,
    const MultipathBpParams& params);

/// One sensor of Leng et al. Algorithm 1. Each step(): W_ji, ν_ji from every neighbour's newest BELIEF
/// (§5.3), then Λ_i = Σ_j W_ji⁻¹ (eq. (3)) and μ_i = Λ_i⁻¹ Σ_j W_ji⁻¹ν_ji (eq. (4)). Beliefs, not cavity
/// messages, are exchanged ([D-4], as printed). Paths come from MeasurementBatch::paths (newest set per peer
/// kept; aoa_here = θ_ji, aoa_there = θ_ij). A neighbour never heard from counts as Λ = 0. If Σ W⁻¹ is
/// singular, μ_i keeps its previous value ("not yet localized").
///
/// Publishes BELIEF {iteration l, μ_i, Λ_i}; the anchor S_0 publishes its known position with
/// infinite_information = true. With exact_messages (not in Leng et al.) the belief also lists each
/// neighbour's message (W_ji⁻¹, W_ji⁻¹ν_ji) as added, and a receiver S_j subtracts its own entry from (Λ_i,
/// Λ_iμ_i) before it forms W_ij: Gaussian BP with cavity messages, exact on trees.
class MultipathBp final : public Estimator {
 public:
  MultipathBp(const AgentSetup& setup, const MultipathBpParams& params);

  [[nodiscard]] std::string_view name() const override { return "multipath_bp"; }
  [[nodiscard]] Outbox initial_outbox() const override;
  StepOutput step(const StepInput& input) override;
  [[nodiscard]] Estimate estimate() const override;

  [[nodiscard]] const Vec2& mean() const { return mu_; }
  [[nodiscard]] const Mat2& information() const { return Lambda_; }
  [[nodiscard]] bool localized() const { return localized_; }

 private:
  [[nodiscard]] Outbox published() const;

  AgentSetup setup_;
  MultipathBpParams params_;
  std::map<AgentId, LinkModel> links_;
  Vec2 mu_;
  Mat2 Lambda_ = Mat2::Zero();
  std::vector<BeliefContribution> contributions_;  ///< exact_messages: the last step's terms of Λ_i
  bool localized_ = false;
  std::int64_t iteration_ = 0;
};

}  // namespace swarmloc::estimators::bp
