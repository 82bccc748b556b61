#pragma once
// Symmetric band matrices and the banded kernels of the centralized family (Khan et al., docs/algorithms.md
// §2.3–§2.6). Storage is LAPACK "SB" lower: entry (i, j) with 0 <= i - j <= L lives at storage(i - j, j).
#include "swarmloc/core/types.hpp"

namespace swarmloc::estimators::centralized {

/// Symmetric n×n matrix with bandwidth L (A_ij = 0 for |i − j| > L), stored as (L+1)×n.
class BandMatrix {
 public:
  BandMatrix() = default;
  /// Zero matrix of size n and bandwidth L (0 <= L <= max(n − 1, 0)).
  BandMatrix(int n, int bandwidth);

  /// The band |i − j| <= bandwidth of a dense symmetric matrix (lower triangle is read).
  static BandMatrix from_dense(const MatX& dense, int bandwidth);
  [[nodiscard]] MatX to_dense() const;

  [[nodiscard]] int size() const { return n_; }
  [[nodiscard]] int bandwidth() const { return bandwidth_; }
  [[nodiscard]] bool in_band(int i, int j) const { return (i >= j ? i - j : j - i) <= bandwidth_; }

  /// Value of A_ij (0 outside the band). O(1).
  [[nodiscard]] double operator()(int i, int j) const {
    if (!in_band(i, j)) return 0.0;
    return i >= j ? storage_(i - j, j) : storage_(j - i, i);
  }
  /// Writable reference to A_ij = A_ji; requires |i − j| <= bandwidth.
  double& ref(int i, int j) { return i >= j ? storage_(i - j, j) : storage_(j - i, i); }

  /// Dense principal submatrix rows/columns start … start+count−1 (entries outside the band are 0).
  [[nodiscard]] MatX principal_block(int start, int count) const;

  /// y = A x in O(nL).
  [[nodiscard]] VecX multiply(const VecX& x) const;
  /// A += value · I.
  void add_diagonal(double value);
  /// A += diag(values).
  void add_diagonal(const VecX& values);
  /// A += B over the band of A (entries of B outside A's band are dropped).
  void add_band_of(const BandMatrix& other);
  void set_zero() { storage_.setZero(); }

  /// (L+1)×n storage, row r = sub-diagonal r.
  [[nodiscard]] const MatX& storage() const { return storage_; }
  MatX& storage() { return storage_; }

 private:
  int n_ = 0;
  int bandwidth_ = 0;
  MatX storage_;
};

/// Largest |i − j| with |A_ij| > tolerance (0 for a diagonal or empty matrix).
int matrix_bandwidth(const MatX& a, double tolerance = 0.0);

/// Banded Cholesky A = G Gᵀ, G lower with the bandwidth of A. O(nL²) time, O(nL) memory.
class BandCholesky {
 public:
  /// Throws std::domain_error if A is not positive definite.
  explicit BandCholesky(const BandMatrix& a);

  /// Solves A x = b in O(nL).
  [[nodiscard]] VecX solve(const VecX& b) const;
  /// The band of A⁻¹ (same bandwidth as A) by the Takahashi recurrences, O(nL²) (docs/algorithms.md §2.4
  ///
  [[nodiscard]] BandMatrix selected_inverse() const;
  /// Lower factor G in band storage.
  [[nodiscard]] const BandMatrix& factor() const { return factor_; }

 private:
  BandMatrix factor_;
};

}  // namespace swarmloc::estimators::centralized
