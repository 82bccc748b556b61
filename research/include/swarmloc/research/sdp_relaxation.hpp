#pragma once
// Full SDP relaxation of range localization (Biswas–Ye form; Calafiore et al. Sec. V-C, docs/algorithms.md
// §6.5 item 4), solved with SDPA. Centralized, one shot: the initial guess of the SDP+DG refinement (Tables
// II–III). Plain C++/Eigen in and out: no I/O, logging, RNG or clock; SDPA is seen only by the .cpp.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "swarmloc/estimators/gradient/dgbb.hpp"

namespace swarmloc::research {

namespace gradient = estimators::gradient;

struct SdpRelaxationParams {
  double epsilon = 1e-7;     ///< SDPA epsilonStar (relative duality gap) and epsilonDash (feasibility)
  int max_iterations = 100;  ///< SDPA maxIteration
  /// SDPA stops at "pdFEAS" (both sides feasible, gap above epsilon) when its search direction fails near the
  /// end; on this relaxation that happens at a relative gap of ~2e−7…2e−6 (the optimal Z has rank 2 ≪ n_u +
  /// 2). pdFEAS with SDPA's relative gap ≤ accept_gap counts as optimal; above it the status is kInaccurate.
  double accept_gap = 1e-5;
};

/// Throws std::invalid_argument naming the offending field.
void validate(const SdpRelaxationParams& params);

enum class SdpStatus {
  kOptimal,     ///< SDPA phase pdOPT, or pdFEAS with relative gap ≤ accept_gap
  kInaccurate,  ///< SDPA stopped feasible but short of the requested accuracy (pdFEAS, pFEAS, dFEAS, noINFO);
                ///< positions are returned, use with care
  kInfeasible,  ///< pINF/dINF/pdINF (cannot happen for a well-formed problem: the relaxation is feasible)
  kUnbounded,   ///< pUNBD/dUNBD
  kFailed,      ///< no usable solution (non-finite output)
};

/// Human-readable status name ("optimal", "inaccurate", …).
const char* to_string(SdpStatus status);

struct SdpRelaxationResult {
  SdpStatus status = SdpStatus::kFailed;
  std::string solver_phase;  ///< SDPA's phase string (e.g. "pdOPT"), for diagnostics
  /// One position per node of the problem: anchors keep their (fixed) position, the others are columns of X.
  std::vector<Vec2> positions;
  /// Node index → column of X / row of Y (−1 for anchors).
  std::vector<int> unknown_index;
  Eigen::MatrixXd gram;       ///< Y ∈ S^{n_u} at the solution
  double total_slack = 0.0;   ///< Σ(a⁺ + a⁻) + Σ(b⁺ + b⁻) at the solution (the minimized objective)
  double max_residual = 0.0;  ///< largest |equality-constraint residual| recomputed from the solution
  double duality_gap = 0.0;   ///< SDPA's relative gap
  /// SDPA's objectives: c·x of its x-form and F_0 • Y of the form posed here (= −Σ slacks); equal at optimum.
  double sdpa_primal_objective = 0.0;
  double sdpa_dual_objective = 0.0;
  int iterations = 0;
  int sensor_sensor_edges = 0;
  int anchor_sensor_edges = 0;

  /// True when positions can be used (optimal or inaccurate-but-finite).
  [[nodiscard]] bool usable() const {
    return status == SdpStatus::kOptimal || status == SdpStatus::kInaccurate;
  }
};

/// Solves   min Σ(a⁺ + a⁻) + Σ(b⁺ + b⁻)
///   s.t.   Z = [[I₂, X], [Xᵀ, Y]] ⪰ 0,
///          Y_ii + Y_jj − 2Y_ij − d̄_ij² = a⁺_ij − a⁻_ij            (sensor–sensor edges)
///          ‖a_k‖² − 2a_kᵀx_j + Y_jj − d̄_kj² = b⁺_kj − b⁻_kj      (anchor–sensor edges)
///          all slacks ≥ 0
/// for `problem` (anchors: problem.anchor[i], their positions problem.initial[i]; problem.initial of the
/// other nodes is ignored). Anchor–anchor edges are constants and are skipped. Throws std::invalid_argument
/// for a malformed problem (index out of range, self edge, non-finite range or anchor position); a solver
/// that does not reach a solution is reported in `status`, never thrown. Thread-safe (SDPA calls are
/// serialized).
SdpRelaxationResult solve_sdp_relaxation(const gradient::RangeProblem& problem,
                                         const SdpRelaxationParams& params = {});

/// The relaxation's objective at a given (X, Y) with the slacks at their best values:
/// Σ_edges |residual of the edge's constraint| (anchor–anchor edges skipped). `positions` has one entry per
/// node (anchors' entries ignored: problem.initial is used), `gram` is Y indexed by `unknown_index`.
/// With Y = XᵀX the residuals are ‖p_i − p_j‖² − d̄_ij².
double sdp_relaxation_objective(const gradient::RangeProblem& problem, const std::vector<Vec2>& positions,
                                const Eigen::MatrixXd& gram, const std::vector<int>& unknown_index);

/// unknown_index for `problem` (the numbering used by solve_sdp_relaxation): non-anchors in node order.
std::vector<int> sdp_unknown_index(const gradient::RangeProblem& problem);

}  // namespace swarmloc::research
