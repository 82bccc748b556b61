#include "swarmloc/estimators/centralized/band_matrix.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace swarmloc::estimators::centralized {

BandMatrix::BandMatrix(int n, int bandwidth) : n_(n), bandwidth_(bandwidth) {
  if (n < 0 || bandwidth < 0 || (n > 0 && bandwidth > n - 1)) {
    throw std::invalid_argument("BandMatrix: bandwidth " + std::to_string(bandwidth) + " is outside [0, " +
                                std::to_string(std::max(n - 1, 0)) + "]");
  }
  storage_ = MatX::Zero(bandwidth + 1, n);
}

BandMatrix BandMatrix::from_dense(const MatX& dense, int bandwidth) {
  const int n = static_cast<int>(dense.rows());
  BandMatrix band(n, std::min(bandwidth, std::max(n - 1, 0)));
  for (int j = 0; j < n; ++j) {
    const int rows = std::min(band.bandwidth_, n - 1 - j) + 1;
    band.storage_.col(j).head(rows) = dense.col(j).segment(j, rows);
  }
  return band;
}

MatX BandMatrix::to_dense() const {
  MatX dense = MatX::Zero(n_, n_);
  for (int j = 0; j < n_; ++j) {
    const int rows = std::min(bandwidth_, n_ - 1 - j) + 1;
    dense.col(j).segment(j, rows) = storage_.col(j).head(rows);
    dense.row(j).segment(j, rows) = storage_.col(j).head(rows).transpose();
  }
  return dense;
}

MatX BandMatrix::principal_block(int start, int count) const {
  MatX block(count, count);
  for (int c = 0; c < count; ++c) {
    for (int r = c; r < count; ++r) {
      const double v = (*this)(start + r, start + c);
      block(r, c) = v;
      block(c, r) = v;
    }
  }
  return block;
}

VecX BandMatrix::multiply(const VecX& x) const {
  VecX y = VecX::Zero(n_);
  for (int j = 0; j < n_; ++j) {
    const int m = std::min(bandwidth_, n_ - 1 - j);
    y(j) += storage_(0, j) * x(j);
    if (m == 0) continue;
    const auto sub = storage_.col(j).segment(1, m);
    y.segment(j + 1, m) += sub * x(j);     // lower part: rows j+1..j+m of column j
    y(j) += sub.dot(x.segment(j + 1, m));  // mirrored upper part
  }
  return y;
}

void BandMatrix::add_diagonal(double value) { storage_.row(0).array() += value; }

void BandMatrix::add_diagonal(const VecX& values) { storage_.row(0) += values.transpose(); }

void BandMatrix::add_band_of(const BandMatrix& other) {
  const int rows = std::min(bandwidth_, other.bandwidth_) + 1;
  storage_.topRows(rows) += other.storage_.topRows(rows);
}

int matrix_bandwidth(const MatX& a, double tolerance) {
  int bandwidth = 0;
  for (int j = 0; j < a.cols(); ++j) {
    for (int i = 0; i < a.rows(); ++i) {
      if (std::abs(a(i, j)) > tolerance) bandwidth = std::max(bandwidth, std::abs(i - j));
    }
  }
  return bandwidth;
}

// Right-looking banded Cholesky: column j of the factor is final once its pivot is taken.
BandCholesky::BandCholesky(const BandMatrix& a) : factor_(a) {
  const int n = a.size();
  const int bw = a.bandwidth();
  MatX& g = factor_.storage();
  for (int j = 0; j < n; ++j) {
    const double pivot = g(0, j);
    if (!(pivot > 0.0) || !std::isfinite(pivot)) {
      throw std::domain_error("BandCholesky: matrix is not positive definite (pivot " + std::to_string(j) +
                              ")");
    }
    const double gjj = std::sqrt(pivot);
    g(0, j) = gjj;
    const int m = std::min(bw, n - 1 - j);
    if (m == 0) continue;
    g.col(j).segment(1, m) /= gjj;
    for (int c = 1; c <= m; ++c) {
      // A(j+c+r, j+c) -= G(j+c+r, j) G(j+c, j), r = 0..m−c.
      g.col(j + c).head(m - c + 1) -= g.col(j).segment(c, m - c + 1) * g(c, j);
    }
  }
}

VecX BandCholesky::solve(const VecX& b) const {
  const int n = factor_.size();
  const int bw = factor_.bandwidth();
  const MatX& g = factor_.storage();
  VecX x = b;
  for (int j = 0; j < n; ++j) {  // G y = b
    x(j) /= g(0, j);
    const int m = std::min(bw, n - 1 - j);
    if (m > 0) x.segment(j + 1, m) -= g.col(j).segment(1, m) * x(j);
  }
  for (int j = n - 1; j >= 0; --j) {  // Gᵀ x = y
    const int m = std::min(bw, n - 1 - j);
    if (m > 0) x(j) -= g.col(j).segment(1, m).dot(x.segment(j + 1, m));
    x(j) /= g(0, j);
  }
  return x;
}

// Takahashi: Σ G = G⁻ᵀ gives, for i >= j, Σ_ij = (δ_ij / G_jj − Σ_{k=j+1}^{j+L} Σ_ik G_kj) / G_jj.
// Sweeping j downwards only touches entries inside the band (docs/algorithms.md §2.6 (iii)).
BandMatrix BandCholesky::selected_inverse() const {
  const int n = factor_.size();
  const int bw = factor_.bandwidth();
  const MatX& g = factor_.storage();
  BandMatrix sigma(n, bw);
  MatX& s = sigma.storage();
  for (int j = n - 1; j >= 0; --j) {
    const int m = std::min(bw, n - 1 - j);
    const double gjj = g(0, j);
    // Rows i = j+m … j+1 first (they need only columns > j), then the diagonal.
    for (int i = j + m; i > j; --i) {
      double acc = 0.0;
      for (int k = j + 1; k <= j + m; ++k) {
        const double sik = i >= k ? s(i - k, k) : s(k - i, i);
        acc += sik * g(k - j, j);
      }
      s(i - j, j) = -acc / gjj;
    }
    double acc = 0.0;
    for (int k = j + 1; k <= j + m; ++k) acc += s(k - j, j) * g(k - j, j);
    s(0, j) = (1.0 / gjj - acc) / gjj;
  }
  return sigma;
}

}  // namespace swarmloc::estimators::centralized
