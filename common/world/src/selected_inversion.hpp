#pragma once
// Selected inversion (Takahashi's recursion) of a sparse LDLᵀ factor: the entries of H⁻¹ on the pattern of
// L, enough for the block marginals of a least-squares solution (the run's optimum, optimum_solver.cpp;
// the pose smoother, pose_smoother.cpp). Private to the world library.
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <vector>

#include "swarmloc/core/types.hpp"

namespace swarmloc::world {

/// Z = H⁻¹ on L's pattern from H = Pᵀ L D Lᵀ P (Eigen's SimplicialLDLT: L unit lower, columns with
/// ascending rows, no diagonal stored). For j from the last column down, with R its rows,
/// Z_Rj = −Z_RR L_Rj and Z_jj = 1/D_j − L_Rjᵀ Z_Rj. Every Z_ik it reads lies in the pattern (R is a clique
/// of the filled graph: R's rows after k are in column k's pattern), so Z_RR L_Rj is a merge of column
/// k = R_q with R, q by q. Columns before `first` (permuted index) are not computed.
class SelectedInverse {
 public:
  template <typename Factor>
  SelectedInverse(const Factor& factor, int first) : L_(factor.matrixL().nestedExpression()) {
    const auto& permutation = factor.permutationP().indices();  // empty: the identity
    permutation_.assign(permutation.data(), permutation.data() + permutation.size());
    compute(factor.vectorD(), first);
  }

  /// The permuted index of unknown k.
  [[nodiscard]] int permuted(std::size_t k) const {
    return permutation_.empty() ? static_cast<int>(k) : permutation_[k];
  }
  /// Z at permuted indices (r, c): 0 off L's pattern.
  [[nodiscard]] double at(int r, int c) const {
    if (r == c) return z_diag_(r);
    const int row = std::max(r, c);
    const int column = std::min(r, c);
    const int* inner = L_.innerIndexPtr();
    const int* begin = inner + L_.outerIndexPtr()[column];
    const int* end = inner + L_.outerIndexPtr()[column + 1];
    const int* hit = std::lower_bound(begin, end, row);  // Z_rc, r != c: column min(r, c), by bisection
    return hit != end && *hit == row ? z_off_[static_cast<std::size_t>(hit - inner)] : 0.0;
  }
  /// H⁻¹ at unknowns (a, b), before permutation.
  [[nodiscard]] double inverse(std::size_t a, std::size_t b) const { return at(permuted(a), permuted(b)); }

 private:
  void compute(const VecX& D, int first) {
    const Eigen::Index n = L_.cols();
    const int* outer = L_.outerIndexPtr();
    const int* inner = L_.innerIndexPtr();
    const double* value = L_.valuePtr();
    z_off_.assign(static_cast<std::size_t>(outer[n]), 0.0);
    z_diag_ = VecX::Zero(n);
    std::vector<double> sum;
    for (Eigen::Index j = n - 1; j >= first; --j) {
      const int from = outer[j];
      const int m = outer[j + 1] - from;
      const int* rows = inner + from;
      const double* l = value + from;
      sum.assign(static_cast<std::size_t>(m), 0.0);  // sum[p] = Σ_q Z(R_p, R_q) l_q
      for (int q = 0; q < m; ++q) {
        const int k = rows[q];
        sum[static_cast<std::size_t>(q)] += z_diag_(k) * l[q];
        int p = q + 1;
        for (int c = outer[k]; c < outer[k + 1] && p < m; ++c) {
          if (inner[c] < rows[p]) continue;
          while (p < m && rows[p] < inner[c]) ++p;  // never in a chordal pattern; kept safe
          if (p < m && rows[p] == inner[c]) {
            const double z = z_off_[static_cast<std::size_t>(c)];  // Z(R_p, k), R_p > k
            sum[static_cast<std::size_t>(p)] += z * l[q];
            sum[static_cast<std::size_t>(q)] += z * l[p];
            ++p;
          }
        }
      }
      double diagonal = 1.0 / D(j);
      for (int p = 0; p < m; ++p) {
        z_off_[static_cast<std::size_t>(from) + static_cast<std::size_t>(p)] =
            -sum[static_cast<std::size_t>(p)];
        diagonal += l[p] * sum[static_cast<std::size_t>(p)];
      }
      z_diag_(j) = diagonal;
    }
  }

  const Eigen::SparseMatrix<double>& L_;
  std::vector<int> permutation_;
  std::vector<double> z_off_;
  VecX z_diag_;
};

}  // namespace swarmloc::world
