#include "swarmloc/research/sdp_relaxation.hpp"

#include <sdpa_call.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <iostream>
#include <mutex>
#include <stdexcept>
#include <streambuf>
#include <string>

namespace swarmloc::research {
namespace {

// SDPA keeps process-wide state inside (timers, MUMPS' sequential MPI stub): one solve at a time.
std::mutex& sdpa_mutex() {
  static std::mutex mutex;
  return mutex;
}

// SDPA's internal diagnostics ("cholesky miss condition", "Strange behavior : primal < dual") go to std::cout
// whatever setDisplay says; they are discarded while SDPA runs (the solver's outcome is in the result).
class DiscardStdCout {
 public:
  DiscardStdCout() : saved_(std::cout.rdbuf(&sink_)) {}
  ~DiscardStdCout() {
    std::cout.rdbuf(saved_);
    std::cout.clear();
  }
  DiscardStdCout(const DiscardStdCout&) = delete;
  DiscardStdCout& operator=(const DiscardStdCout&) = delete;

 private:
  struct Sink final : std::streambuf {
    int overflow(int c) override { return traits_type::not_eof(c); }
  };
  Sink sink_;
  std::streambuf* saved_;
};

// An edge of the relaxation: two unknowns (u, v ≥ 0) or one unknown u and an anchor position.
struct SdpEdge {
  int u = -1;
  int v = -1;  ///< −1: anchor–sensor edge
  Vec2 anchor = Vec2::Zero();
  double range = 0.0;
};

std::vector<SdpEdge> relaxation_edges(const gradient::RangeProblem& problem,
                                      const std::vector<int>& unknown_index) {
  const auto n = static_cast<int>(problem.anchor.size());
  if (problem.initial.size() != problem.anchor.size())
    throw std::invalid_argument("sdp_relaxation: initial and anchor sizes differ");
  std::vector<SdpEdge> edges;
  for (std::size_t k = 0; k < problem.edges.size(); ++k) {
    const gradient::RangeEdge& e = problem.edges[k];
    const std::string where = "sdp_relaxation: edge " + std::to_string(k);
    if (e.i < 0 || e.i >= n || e.j < 0 || e.j >= n)
      throw std::invalid_argument(where + ": node index out of range");
    if (e.i == e.j) throw std::invalid_argument(where + ": self edge");
    if (!std::isfinite(e.range_m) || e.range_m < 0.0)
      throw std::invalid_argument(where + ": range must be finite and >= 0");
    const int ui = unknown_index[static_cast<std::size_t>(e.i)];
    const int uj = unknown_index[static_cast<std::size_t>(e.j)];
    if (ui < 0 && uj < 0) continue;  // anchor–anchor: a constant, not part of the relaxation
    SdpEdge edge;
    edge.range = e.range_m;
    if (ui >= 0 && uj >= 0) {
      edge.u = ui;
      edge.v = uj;
    } else {
      edge.u = ui >= 0 ? ui : uj;
      edge.anchor = problem.initial[static_cast<std::size_t>(ui >= 0 ? e.j : e.i)];
      if (!edge.anchor.allFinite()) throw std::invalid_argument(where + ": anchor position is not finite");
    }
    edges.push_back(edge);
  }
  return edges;
}

// Residual of one edge constraint (docs/algorithms.md §6.5 item 4) at (X, Y):
//   sensor–sensor: Y_uu + Y_vv − 2Y_uv − d̄²;   anchor–sensor: ‖a‖² − 2aᵀx_u + Y_uu − d̄².
double edge_residual(const SdpEdge& e, const Eigen::Matrix2Xd& X, const Eigen::MatrixXd& Y) {
  const double d2 = e.range * e.range;
  if (e.v >= 0) return Y(e.u, e.u) + Y(e.v, e.v) - 2.0 * Y(e.u, e.v) - d2;
  return e.anchor.squaredNorm() - 2.0 * e.anchor.dot(X.col(e.u)) + Y(e.u, e.u) - d2;
}

SdpStatus status_of(SDPA::PhaseType phase, double gap, const SdpRelaxationParams& params) {
  switch (phase) {
    case SDPA::pdOPT:
      return SdpStatus::kOptimal;
    case SDPA::pdFEAS:
      return gap <= params.accept_gap ? SdpStatus::kOptimal : SdpStatus::kInaccurate;
    case SDPA::pFEAS:
    case SDPA::dFEAS:
    case SDPA::noINFO:
      return SdpStatus::kInaccurate;
    case SDPA::pdINF:
    case SDPA::pFEAS_dINF:
    case SDPA::pINF_dFEAS:
      return SdpStatus::kInfeasible;
    case SDPA::pUNBD:
    case SDPA::dUNBD:
      return SdpStatus::kUnbounded;
  }
  return SdpStatus::kFailed;
}

// SDPA's standard form (sdpa_call.h; SDPA 7 manual §2):
//   (P) min Σ_k c_k x_k  s.t.  X = Σ_k F_k x_k − F_0 ⪰ 0
//   (D) max F_0 • Y      s.t.  F_k • Y = c_k (k = 1…m),  Y ⪰ 0
// The relaxation is posed as (D): its Y (getResultYMat) is block 1 = Z (n_u + 2 square, SDP) and block 2 =
// the slacks (diagonal LP block, (a⁺, a⁻) per edge); F_0 = −1 on the slacks, so max F_0 • Y = −Σ slacks.
// inputElement(k, block, i, j, v) with i ≤ j sets F_k(i, j) = F_k(j, i) = v (1-based): an off-diagonal
// entry contributes 2·v·Y_ij to F_k • Y.
void pose_relaxation(SDPA& sdpa, const std::vector<SdpEdge>& edges, int n_u,
                     const SdpRelaxationParams& params) {
  const int dim = n_u + 2;
  const int num_edges = static_cast<int>(edges.size());
  const int m = 3 + num_edges;
  auto z = [](int unknown) { return unknown + 3; };  // 1-based row/column of x_u, Y_u· inside Z

  sdpa.setDisplay(nullptr);  // SDPA prints its iterations to stdout by default
  sdpa.setResultFile(nullptr);
  sdpa.setParameterType(SDPA::PARAMETER_DEFAULT);
  sdpa.setParameterMaxIteration(params.max_iterations);
  sdpa.setParameterEpsilonStar(params.epsilon);
  sdpa.setParameterEpsilonDash(params.epsilon);
  sdpa.setNumThreads(1);
  sdpa.inputConstraintNumber(m);
  sdpa.inputBlockNumber(num_edges > 0 ? 2 : 1);
  sdpa.inputBlockSize(1, dim);
  sdpa.inputBlockType(1, SDPA::SDP);
  if (num_edges > 0) {
    sdpa.inputBlockSize(2, -2 * num_edges);  // negative size: an LP (diagonal) block
    sdpa.inputBlockType(2, SDPA::LP);
  }
  sdpa.initializeUpperTriangleSpace();

  // Z(1:2, 1:2) = I₂.
  sdpa.inputCVec(1, 1.0);
  sdpa.inputElement(1, 1, 1, 1, 1.0);
  sdpa.inputCVec(2, 1.0);
  sdpa.inputElement(2, 1, 2, 2, 1.0);
  sdpa.inputCVec(3, 0.0);
  sdpa.inputElement(3, 1, 1, 2, 0.5);  // 2 · 0.5 · Z_12 = 0
  for (int k = 0; k < num_edges; ++k) {
    const SdpEdge& e = edges[static_cast<std::size_t>(k)];
    const int row = 4 + k;
    const int u = z(e.u);
    const double d2 = e.range * e.range;
    if (e.v >= 0) {  // Y_uu + Y_vv − 2Y_uv − a⁺ + a⁻ = d̄²
      const int v = z(e.v);
      sdpa.inputCVec(row, d2);
      sdpa.inputElement(row, 1, u, u, 1.0);
      sdpa.inputElement(row, 1, v, v, 1.0);
      sdpa.inputElement(row, 1, std::min(u, v), std::max(u, v), -1.0);
    } else {  // −2aᵀx_u + Y_uu − b⁺ + b⁻ = d̄² − ‖a‖²
      sdpa.inputCVec(row, d2 - e.anchor.squaredNorm());
      if (e.anchor.x() != 0.0) sdpa.inputElement(row, 1, 1, u, -e.anchor.x());
      if (e.anchor.y() != 0.0) sdpa.inputElement(row, 1, 2, u, -e.anchor.y());
      sdpa.inputElement(row, 1, u, u, 1.0);
    }
    sdpa.inputElement(row, 2, 2 * k + 1, 2 * k + 1, -1.0);  // −a⁺
    sdpa.inputElement(row, 2, 2 * k + 2, 2 * k + 2, 1.0);   // +a⁻
  }
  for (int s = 1; s <= 2 * num_edges; ++s) sdpa.inputElement(0, 2, s, s, -1.0);  // F_0: −Σ slacks
}

// Reads SDPA's solution into `result` (status, Gram block, residual check, total slack); returns X.
Eigen::Matrix2Xd read_relaxation(SDPA& sdpa, const std::vector<SdpEdge>& edges, int n_u,
                                 const SdpRelaxationParams& params, SdpRelaxationResult& result) {
  const int dim = n_u + 2;
  const int num_edges = static_cast<int>(edges.size());
  char phase[64] = {};
  sdpa.getPhaseString(phase);
  result.solver_phase = phase;
  result.iterations = sdpa.getIteration();
  result.duality_gap = sdpa.getDualityGap();
  result.sdpa_primal_objective = sdpa.getPrimalObj();
  result.sdpa_dual_objective = sdpa.getDualObj();
  result.status = status_of(sdpa.getPhaseValue(), result.duality_gap, params);

  const double* Z = sdpa.getResultYMat(1);  // column-major dim × dim
  Eigen::Matrix2Xd X(2, n_u);
  for (int u = 0; u < n_u; ++u) {
    X(0, u) = Z[0 + static_cast<std::ptrdiff_t>(dim) * (u + 2)];
    X(1, u) = Z[1 + static_cast<std::ptrdiff_t>(dim) * (u + 2)];
    for (int v = 0; v < n_u; ++v) result.gram(u, v) = Z[(u + 2) + static_cast<std::ptrdiff_t>(dim) * (v + 2)];
  }
  Eigen::VectorXd slacks = Eigen::VectorXd::Zero(2 * num_edges);
  if (num_edges > 0) {
    const double* lp = sdpa.getResultYMat(2);
    for (int s = 0; s < 2 * num_edges; ++s) slacks(s) = lp[s];
  }
  // Residuals recomputed from the returned point: a check on the formulation and the solve.
  double residual = std::max({std::abs(Z[0] - 1.0), std::abs(Z[1 + dim] - 1.0), std::abs(Z[dim])});
  for (int k = 0; k < num_edges; ++k) {
    const double r = edge_residual(edges[static_cast<std::size_t>(k)], X, result.gram);
    residual = std::max(residual, std::abs(r - (slacks(2 * k) - slacks(2 * k + 1))));
  }
  result.max_residual = residual;
  result.total_slack = slacks.sum();
  return X;
}

}  // namespace

void validate(const SdpRelaxationParams& params) {
  if (!(params.epsilon > 0.0 && params.epsilon < 1.0))
    throw std::invalid_argument("sdp_relaxation.epsilon: must be in (0, 1)");
  if (params.max_iterations < 1) throw std::invalid_argument("sdp_relaxation.max_iterations: must be >= 1");
  if (!(params.accept_gap >= 0.0)) throw std::invalid_argument("sdp_relaxation.accept_gap: must be >= 0");
}

const char* to_string(SdpStatus status) {
  switch (status) {
    case SdpStatus::kOptimal:
      return "optimal";
    case SdpStatus::kInaccurate:
      return "inaccurate";
    case SdpStatus::kInfeasible:
      return "infeasible";
    case SdpStatus::kUnbounded:
      return "unbounded";
    case SdpStatus::kFailed:
      return "failed";
  }
  return "failed";
}

std::vector<int> sdp_unknown_index(const gradient::RangeProblem& problem) {
  std::vector<int> index(problem.anchor.size(), -1);
  int next = 0;
  for (std::size_t i = 0; i < problem.anchor.size(); ++i) {
    if (!problem.anchor[i]) index[i] = next++;
  }
  return index;
}

double sdp_relaxation_objective(const gradient::RangeProblem& problem, const std::vector<Vec2>& positions,
                                const Eigen::MatrixXd& gram, const std::vector<int>& unknown_index) {
  const std::vector<SdpEdge> edges = relaxation_edges(problem, unknown_index);
  const int n_u = static_cast<int>(
      std::count_if(unknown_index.begin(), unknown_index.end(), [](int u) { return u >= 0; }));
  if (gram.rows() != n_u || gram.cols() != n_u || positions.size() != problem.anchor.size())
    throw std::invalid_argument("sdp_relaxation_objective: sizes do not match the problem");
  Eigen::Matrix2Xd X(2, n_u);
  for (std::size_t i = 0; i < unknown_index.size(); ++i) {
    if (unknown_index[i] >= 0) X.col(unknown_index[i]) = positions[i];
  }
  double sum = 0.0;
  for (const SdpEdge& e : edges) sum += std::abs(edge_residual(e, X, gram));  // best a⁺ − a⁻ = residual
  return sum;
}

SdpRelaxationResult solve_sdp_relaxation(const gradient::RangeProblem& problem,
                                         const SdpRelaxationParams& params) {
  validate(params);
  SdpRelaxationResult result;
  result.unknown_index = sdp_unknown_index(problem);
  const std::vector<SdpEdge> edges = relaxation_edges(problem, result.unknown_index);
  const int n_u = static_cast<int>(
      std::count_if(result.unknown_index.begin(), result.unknown_index.end(), [](int u) { return u >= 0; }));
  for (std::size_t i = 0; i < problem.anchor.size(); ++i) {
    if (problem.anchor[i] && !problem.initial[i].allFinite())
      throw std::invalid_argument("sdp_relaxation: anchor " + std::to_string(i) + " position is not finite");
  }
  result.positions = problem.initial;
  result.gram = Eigen::MatrixXd::Zero(n_u, n_u);
  for (const SdpEdge& e : edges) ++(e.v >= 0 ? result.sensor_sensor_edges : result.anchor_sensor_edges);
  if (n_u == 0) {  // nothing to estimate
    result.status = SdpStatus::kOptimal;
    result.solver_phase = "trivial";
    return result;
  }

  std::lock_guard<std::mutex> lock(sdpa_mutex());
  const DiscardStdCout quiet;
  SDPA sdpa;
  pose_relaxation(sdpa, edges, n_u, params);
  sdpa.initializeUpperTriangle();
  sdpa.initializeSolve();
  sdpa.solve();
  const Eigen::Matrix2Xd X = read_relaxation(sdpa, edges, n_u, params, result);
  sdpa.terminate();

  if (!X.allFinite() || !result.gram.allFinite() || !std::isfinite(result.max_residual)) {
    result.status = SdpStatus::kFailed;
    return result;
  }
  for (std::size_t i = 0; i < problem.anchor.size(); ++i) {
    const int u = result.unknown_index[i];
    if (u >= 0) result.positions[i] = X.col(u);
  }
  return result;
}

}  // namespace swarmloc::research
