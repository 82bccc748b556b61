#pragma once
// Distributed gradient localization with a consensus Barzilai–Borwein step (Calafiore et al.,
// docs/algorithms.md §6) and its baselines: local BB (T = 0), fixed step, specified step length; centralized
// BB as a plain function.
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string_view>
#include <vector>

#include "swarmloc/estimators/consensus/metropolis.hpp"
#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/gradient/params.hpp"

namespace swarmloc::estimators::gradient {

/// Throws std::invalid_argument naming the offending field.
void validate(const DgBbParams& params);

/// One agent of DG-BB or a baseline. ONE step() = ONE communication round. Per update τ the DG-BB node
/// spends T + 1 rounds: round 0 uses the neighbours' STATE p_j^(τ) to form D_i(p^(τ)), ρ_i(0) = ‖Δp_i‖²,
/// ψ_i(0) = Δp_iᵀΔD_i (Calafiore et al. eqs. (8)–(9)) and publishes them; rounds 1…T average the neighbours'
/// newest (ρ_j, ψ_j) with Metropolis weights (eqs. (10)–(11), [E-3]); round T then updates p_i (eq. (14)) and
/// publishes the new STATE. The baselines update in every round (one STATE exchange per update).
///
/// Publishes every round: STATE {p_i^(τ), covariance 0, anchor, active, degree}; DG-BB also publishes
/// CONS {τ, t, [ρ_i, ψ_i]} in rounds 0…T−1. Ranges d̄_ij come from MeasurementBatch::ranges (newest kept);
/// the degree is the number of range neighbours. Anchors and inactive nodes keep publishing and relay
/// consensus with ρ = ψ = 0 ([E-5]). Until every range neighbour's STATE has been received, the node waits
/// (publishes, does not update) — the §6.4 start rule. Missing consensus values reuse the newest received;
/// a neighbour never heard from in consensus is replaced by the node's own value.
class DgBb final : public Estimator {
 public:
  DgBb(const AgentSetup& setup, const DgBbParams& params);

  [[nodiscard]] std::string_view name() const override;
  [[nodiscard]] Outbox initial_outbox() const override;
  StepOutput step(const StepInput& input) override;
  [[nodiscard]] Estimate estimate() const override;

  [[nodiscard]] const Vec2& position() const { return p_; }
  /// Still updating (anchors: never active; stops when the correction ≤ η or τ ≥ τ_max).
  [[nodiscard]] bool active() const { return active_ && tau_ < params_.max_updates; }
  /// Updates performed so far, warm-up included (τ).
  [[nodiscard]] std::int64_t updates() const { return tau_; }
  /// α used in the last update (NaN before the first BB update).
  [[nodiscard]] double last_step() const { return last_alpha_; }
  /// How often the [E-4] safeguard replaced α at this (active, non-anchor) node.
  [[nodiscard]] int safeguard_count() const { return safeguard_count_; }
  /// How often the max_move_fraction trust region shortened a BB step at this (active) node.
  [[nodiscard]] int trust_region_count() const { return trust_region_count_; }
  /// Current consensus values (ρ_i(t), ψ_i(t)) and round t (DG-BB only).
  [[nodiscard]] double rho() const { return rho_; }
  [[nodiscard]] double psi() const { return psi_; }
  [[nodiscard]] int round() const { return round_; }

 private:
  enum class Phase { kWaiting, kWarmup, kRound };

  /// Writes what the node publishes into the empty `outbox` (step() fills its StepOutput's in place, which
  /// spares a move per round).
  void publish(Outbox& outbox, bool with_consensus) const;
  /// D_i(p) = grad_scale · Σ_j g_ij (p_i − p_j), g_ij = ‖p_i − p_j‖² − d̄_ij² ([E-1]); false if a neighbour is
  /// missing.
  bool direction(Vec2& D) const;
  /// The same with node i at `position` (the neighbours' newest positions unchanged).
  bool direction_at(const Vec2& position, Vec2& D) const;
  void apply_update(const Vec2& D, double alpha);
  /// α capped by max_step and by the max_move_fraction trust region (counted in trust_region_count_).
  double capped_bb_step(double alpha, const Vec2& D);
  void consensus_round();
  /// Takes in the step's ranges and each peer's newest STATE and CONS.
  void absorb(const StepInput& input);
  /// α at direction D under the rules without consensus rounds (fixed, step length, local BB).
  double local_step(const Vec2& D);
  /// One consensus round of DG-BB (Calafiore et al. eqs. (8)–(11)); at round T, eq. (12) and the update.
  void consensus_step(StepOutput& out);

  AgentSetup setup_;
  DgBbParams params_;
  Vec2 p_;
  Vec2 p_prev_;
  Vec2 D_prev_ = Vec2::Zero();
  Vec2 D_cur_ = Vec2::Zero();
  bool have_prev_ = false;
  /// What the node knows of one peer: its range, if measured, and the newest STATE and CONS received.
  struct Peer {
    AgentId id = 0;
    bool has_range = false;
    double range = 0.0;  ///< d̄_ij, the newest
    Vec2 position = Vec2::Zero();
    int degree = 0;
    bool have_state = false;
    double rho = 0.0;
    double psi = 0.0;
    bool have_consensus = false;
    /// Metropolis weight W_ij, computed for the neighbour degree `weight_degree` (0: not computed yet, or
    /// the node's own degree has changed since).
    int weight_degree = 0;
    double weight = 0.0;
  };
  /// Index in peers_ of the peer `id`, added (knowing nothing) if new.
  std::size_t peer_index(AgentId id);
  /// The peer `id` of an inbox entry, tried first at `hint` (where that entry's sender was found in the
  /// previous step; updated): an inbox lists the same senders in the same order step after step, so this
  /// spares nearly every search.
  Peer& inbox_peer(std::size_t& hint, AgentId id);
  /// Sorted by id, so range neighbours are summed in the same order everywhere. A flat vector rather than
  /// maps: every round looks each neighbour up two or three times, and a node has only a few.
  std::vector<Peer> peers_;
  int range_count_ = 0;                       ///< peers with a range: the node's degree
  std::vector<std::size_t> state_hints_;      ///< inbox_peer() hint per entry of Inbox::states
  std::vector<std::size_t> consensus_hints_;  ///< and of Inbox::consensus
  Phase phase_ = Phase::kWaiting;
  std::int64_t tau_ = 0;
  int round_ = 0;
  double rho_ = 0.0;
  double psi_ = 0.0;
  bool active_ = true;
  double last_alpha_;
  double last_valid_alpha_;
  bool have_valid_alpha_ = false;
  int safeguard_count_ = 0;
  int trust_region_count_ = 0;
};

// ---- Centralized reference (Calafiore et al. eqs. (3)–(5), docs/algorithms.md §6.5 item 5) ----
struct RangeEdge {
  int i = 0;
  int j = 0;
  double range_m = 0.0;  ///< d̄_ij
};
struct RangeProblem {
  std::vector<Vec2> initial;  ///< p^(0); anchors: their true position
  std::vector<bool> anchor;
  std::vector<RangeEdge> edges;
};

/// D(p) for every node (zero rows for anchors), docs/algorithms.md §6.1 [E-1].
std::vector<Vec2> direction(const RangeProblem& problem, const std::vector<Vec2>& p, double grad_scale = 1.0);
/// Objective f(p) = ½ Σ g_ij² (Calafiore et al. eq. (1)).
double objective(const RangeProblem& problem, const std::vector<Vec2>& p);
/// Centralized BB step ‖Δp‖²/(ΔpᵀΔD) over all nodes (Calafiore et al. eq. (5)).
double centralized_bb_step(const std::vector<Vec2>& dp, const std::vector<Vec2>& dD);

struct CentralizedBbResult {
  std::vector<Vec2> positions;
  std::int64_t updates = 0;   ///< τ_end (warm-up included)
  std::vector<double> steps;  ///< α_τ of every BB update
};
/// Gradient with the global BB step (the T → ∞ limit of DG-BB): warm-up with α̃, then α_τ from eq. (5);
/// per-node stopping as in DG-BB (a node whose correction is ≤ η freezes).
CentralizedBbResult centralized_bb(const RangeProblem& problem, const DgBbParams& params);

}  // namespace swarmloc::estimators::gradient
