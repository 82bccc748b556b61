// The sparse least-squares solver of the run's optimum (docs/algorithms.md §1.3.2): Levenberg–Marquardt
// on the normal equations with Eigen's SimplicialLDLT, and the marginal covariances by selected inversion.
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <limits>

#include "selected_inversion.hpp"
#include "swarmloc/world/optimum.hpp"

namespace swarmloc::world {
namespace {

using SparseMatrix = Eigen::SparseMatrix<double>;
/// AMD ordering (a static network), or the blocks' own order (a trajectory numbered time-major, whose band
/// AMD does not improve on: 30 % faster on scenarios/ea2.yaml).
using AmdFactor = Eigen::SimplicialLDLT<SparseMatrix>;
using BandFactor = Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower, Eigen::NaturalOrdering<int>>;
using Triplet = Eigen::Triplet<double>;

constexpr int kMaxIterations = 100;  ///< from the truth: 3–6 (Newton steps converge quadratically)
constexpr int kMaxDampingTries = 60;
/// An undamped Newton step below this (m, relative to max(1, the largest coordinate)) is the last: Newton
/// converges quadratically, so the next one would move ~1e-12 m (coordinates of ~10² m, curvature ~1/10 m).
constexpr double kStepTolerance = 1e-7;
/// A pivot below this fraction of the largest one: the information is singular (not localizable).
constexpr double kSingularPivot = 1e-13;

/// A block's point and matrix: D = 2 (planar) or 3.
template <int D>
using BlockVec = Eigen::Matrix<double, D, 1>;
template <int D>
using BlockMat = Eigen::Matrix<double, D, D>;

template <int D>
BlockVec<D> other_end(const OptimumRangeFactorOf<D>& f, const std::vector<BlockVec<D>>& x) {
  return f.b < 0 ? f.known_b : x[static_cast<std::size_t>(f.b)];
}

/// Residual of a linear factor: value − x_a (unary) or value − (x_b − x_a).
template <int D>
BlockVec<D> linear_residual(const OptimumLinearFactorOf<D>& f, const std::vector<BlockVec<D>>& x) {
  const BlockVec<D>& xa = x[static_cast<std::size_t>(f.a)];
  return f.b < 0 ? BlockVec<D>(f.value - xa) : BlockVec<D>(f.value - (x[static_cast<std::size_t>(f.b)] - xa));
}

template <int D>
double cost_of(const OptimumProblemOf<D>& p, const std::vector<BlockVec<D>>& x) {
  double cost = 0.0;
  for (const auto& f : p.ranges) {
    const double e = f.mean_range_m - (x[static_cast<std::size_t>(f.a)] - other_end(f, x)).norm();
    cost += f.information * e * e;
  }
  for (const auto& f : p.linear) {
    const BlockVec<D> e = linear_residual(f, x);
    cost += e.dot(f.information * e);
  }
  return cost;
}

/// The normal equations H dx = g at an iterate (g = −½∇cost), H either the Gauss–Newton information JᵀΛJ
/// or Newton's Hessian ½∇²cost. The entries come in the same order at every iterate: the first assembly
/// builds the pattern from triplets and records each entry's slot in the compressed matrix, later ones add
/// each value into its slot (no triplets, no sort).
template <int D>
class NormalSystem {
 public:
  explicit NormalSystem(Eigen::Index size) : H(size, size), gradient(VecX::Zero(size)) {}

  void assemble(const OptimumProblemOf<D>& p, const std::vector<BlockVec<D>>& x, bool newton) {
    const bool first = slot_.empty();
    gradient.setZero();
    cursor_ = 0;
    if (first) {
      triplets_.reserve(static_cast<std::size_t>(H.rows()) + 16 * p.ranges.size() + 16 * p.linear.size());
      // Every diagonal entry is in the pattern (the damping adds to it), even for a block no factor touches.
      for (Eigen::Index k = 0; k < H.rows(); ++k) triplets_.emplace_back(k, k, 0.0);
    } else {
      std::fill(H.valuePtr(), H.valuePtr() + H.nonZeros(), 0.0);
      cursor_ = static_cast<std::size_t>(H.rows());  // the diagonal's zeros
    }
    for (const auto& f : p.ranges) {
      const BlockVec<D> d = x[static_cast<std::size_t>(f.a)] - other_end(f, x);
      const double distance = d.norm();
      const BlockVec<D> u =
          distance > 0.0 ? BlockVec<D>(d / distance) : BlockVec<D>::Zero();  // ∂‖x_a − x_b‖/∂x_a
      const double e = f.mean_range_m - distance;
      BlockMat<D> block = f.information * u * u.transpose();
      // Newton: − w e ∂²‖x_a − x_b‖/∂x_a² = − w e (I − uuᵀ)/‖x_a − x_b‖ (indefinite far from the minimum).
      if (newton && distance > 0.0)
        block -= f.information * e / distance * (BlockMat<D>::Identity() - u * u.transpose());
      add_pair(f.a, f.b, block, f.information * e * u);
    }
    for (const auto& f : p.linear) {
      const BlockVec<D> weighted = f.information * linear_residual(f, x);
      // Unary: ∂r/∂x_a = −I; binary: ∂r/∂x_a = I, ∂r/∂x_b = −I. Both give JᵀΛe = ∓Λe at a.
      add_pair(f.a, f.b, f.information, f.b < 0 ? weighted : BlockVec<D>(-weighted));
    }
    if (first) {
      H.setFromTriplets(triplets_.begin(), triplets_.end());
      find_slots();
      triplets_ = {};
    }
  }

  SparseMatrix H;
  VecX gradient;

 private:
  void add_block(int row_block, int column_block, const BlockMat<D>& block) {
    for (int r = 0; r < D; ++r) {
      for (int c = 0; c < D; ++c) {
        if (slot_.empty()) {
          triplets_.emplace_back(D * row_block + r, D * column_block + c, block(r, c));
        } else {
          H.valuePtr()[slot_[cursor_++]] += block(r, c);
        }
      }
    }
  }

  /// The four blocks of a factor between a and b (b < 0: a's diagonal only), ∂r/∂x_a = −∂r/∂x_b.
  void add_pair(int a, int b, const BlockMat<D>& block, const BlockVec<D>& gradient_a) {
    add_block(a, a, block);
    gradient.template segment<D>(D * a) += gradient_a;
    if (b < 0) return;
    add_block(b, b, block);
    add_block(a, b, -block);
    add_block(b, a, -block);
    gradient.template segment<D>(D * b) -= gradient_a;
  }

  /// Each triplet's index in H's values (setFromTriplets leaves each column's rows sorted).
  void find_slots() {
    slot_.resize(triplets_.size());
    const int* outer = H.outerIndexPtr();
    const int* inner = H.innerIndexPtr();
    for (std::size_t t = 0; t < triplets_.size(); ++t) {
      const int* begin = inner + outer[triplets_[t].col()];
      const int* end = inner + outer[triplets_[t].col() + 1];
      slot_[t] = static_cast<int>(std::lower_bound(begin, end, triplets_[t].row()) - inner);
    }
  }

  std::vector<Triplet> triplets_;  ///< the first assembly's
  std::vector<int> slot_;          ///< per entry, in assembly order
  std::size_t cursor_ = 0;
};

/// Whether the factorization holds a positive definite matrix (every pivot above kSingularPivot of the
/// largest).
template <typename Factor>
bool positive_definite(const Factor& factor) {
  if (factor.info() != Eigen::Success) return false;
  const VecX& d = factor.vectorD();
  if (d.size() == 0) return true;
  const double largest = d.maxCoeff();
  return largest > 0.0 && d.minCoeff() > kSingularPivot * largest;
}

enum class StepResult { kAccepted, kConverged, kStuck };

/// One Levenberg–Marquardt step on Newton's Hessian, damped by λ·|diag H| until it is positive definite
/// and lowers the cost (λ adapted in place). Converged when the undamped step, taken, moves no coordinate by
/// more than `tolerance` (taken without a cost test: that close to the minimum, rounding decides the sign
/// of the change); stuck if no damping lowers the cost.
template <int D, typename Factor>
StepResult lm_step(const OptimumProblemOf<D>& p, NormalSystem<D>& system, Factor& factor,
                   std::vector<BlockVec<D>>& x, double& cost, double& lambda, double tolerance) {
  const VecX diagonal = system.H.diagonal();
  const double floor = 1e-12 * std::max(1.0, diagonal.cwiseAbs().maxCoeff());
  for (int attempt = 0; attempt < kMaxDampingTries; ++attempt) {
    for (Eigen::Index k = 0; k < diagonal.size(); ++k)
      system.H.coeffRef(k, k) = diagonal(k) + lambda * (std::abs(diagonal(k)) + floor);
    factor.factorize(system.H);
    if (positive_definite(factor)) {
      const VecX dx = factor.solve(system.gradient);
      std::vector<BlockVec<D>> trial = x;
      for (std::size_t b = 0; b < x.size(); ++b)
        trial[b] += dx.template segment<D>(D * static_cast<Eigen::Index>(b));
      const bool small = dx.allFinite() && dx.cwiseAbs().maxCoeff() < tolerance;
      const double trial_cost = cost_of(p, trial);
      if (small || (dx.allFinite() && trial_cost <= cost)) {
        x = std::move(trial);
        cost = trial_cost;
        const bool converged = small && lambda == 0.0;
        lambda = lambda < 1e-6 ? 0.0 : lambda / 10.0;
        return converged ? StepResult::kConverged : StepResult::kAccepted;
      }
    }
    lambda = lambda == 0.0 ? 1e-4 : lambda * 10.0;
  }
  return StepResult::kStuck;
}

template <int D>
double coordinate_scale(const std::vector<BlockVec<D>>& x) {
  double scale = 1.0;
  for (const auto& v : x) scale = std::max(scale, v.cwiseAbs().maxCoeff());
  return scale;
}

/// Each block's D×D marginal of H⁻¹ by selected inversion (selected_inversion.hpp). Column j needs only the
/// columns after it: the recursion stops at the first column a wanted block uses.
template <int D, typename Factor>
std::vector<BlockMat<D>> marginal_covariances(const Factor& factor, std::size_t blocks,
                                              std::size_t first_block) {
  const auto& permutation = factor.permutationP().indices();  // empty: the identity
  auto permuted = [&](std::size_t k) {
    return permutation.size() == 0 ? static_cast<int>(k) : permutation(static_cast<Eigen::Index>(k));
  };
  int first = static_cast<int>(factor.matrixL().nestedExpression().cols());
  for (std::size_t k = D * first_block; k < D * blocks; ++k) first = std::min(first, permuted(k));
  const SelectedInverse z(factor, first);
  std::vector<BlockMat<D>> out(blocks, BlockMat<D>::Zero());
  for (std::size_t b = first_block; b < blocks; ++b) {
    for (std::size_t r = 0; r < D; ++r) {
      for (std::size_t c = r; c < D; ++c) {
        const auto row = static_cast<Eigen::Index>(r);
        const auto column = static_cast<Eigen::Index>(c);
        out[b](row, column) = out[b](column, row) = z.inverse(D * b + r, D * b + c);
      }
    }
  }
  return out;
}

template <int D, typename Factor>
OptimumSolutionOf<D> solve_with(const OptimumProblemOf<D>& p, bool covariance) {
  OptimumSolutionOf<D> solution;
  solution.x = p.start;
  const auto size = static_cast<Eigen::Index>(D * p.start.size());
  if (size == 0) {
    solution.converged = true;
    return solution;
  }
  NormalSystem<D> system(size);
  Factor factor;
  // Localizable at all? The Fisher information at the start (the truth) must be positive definite; if it is
  // not, no iteration can fix it (a world of 10⁴ agents, not checked by world.require_localizable, spent
  // 100 damped iterations on one agent of degree 1).
  system.assemble(p, solution.x, false);
  factor.analyzePattern(system.H);  // the pattern is the same at every iterate
  factor.factorize(system.H);
  if (!positive_definite(factor)) {
    solution.singular = true;
    return solution;
  }
  system.assemble(p, solution.x, true);
  solution.cost = cost_of(p, solution.x);
  double lambda = 0.0;
  for (int iteration = 0; iteration < kMaxIterations; ++iteration) {
    const double tolerance = kStepTolerance * coordinate_scale(solution.x);
    const StepResult step = lm_step(p, system, factor, solution.x, solution.cost, lambda, tolerance);
    if (step == StepResult::kStuck) break;
    ++solution.iterations;
    if (step == StepResult::kConverged) {
      solution.converged = true;
      break;
    }
    system.assemble(p, solution.x, true);
  }
  // The covariance is the inverse of the Fisher (Gauss–Newton) information at the solution.
  system.assemble(p, solution.x, false);
  factor.factorize(system.H);
  if (!positive_definite(factor)) {
    // Singular at the solution only (it is not at the start): the ML itself sits at a degenerate point
    // (no covariance there, the solution stands).
    solution.singular_at_solution = true;
    return solution;
  }
  if (covariance)
    solution.covariance =
        marginal_covariances<D>(factor, p.start.size(), std::min(p.marginals_from, p.start.size()));
  return solution;
}

}  // namespace

OptimumSolution solve_optimum_problem(const OptimumProblem& p, bool covariance) {
  return p.keep_order ? solve_with<2, BandFactor>(p, covariance) : solve_with<2, AmdFactor>(p, covariance);
}

OptimumSolution3 solve_optimum_problem(const OptimumProblem3& p, bool covariance) {
  return p.keep_order ? solve_with<3, BandFactor>(p, covariance) : solve_with<3, AmdFactor>(p, covariance);
}

}  // namespace swarmloc::world
