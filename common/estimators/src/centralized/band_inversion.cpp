#include "swarmloc/estimators/centralized/band_inversion.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace swarmloc::estimators::centralized {
namespace {

void check_bandwidth(int n, int bandwidth) {
  if (bandwidth < 0 || (n > 0 && bandwidth > n - 1)) {
    throw std::invalid_argument("band_inverse: L = " + std::to_string(bandwidth) + " is outside [0, " +
                                std::to_string(std::max(n - 1, 0)) + "]");
  }
}

// Inverse of an SPD window; throws if it is not PD (docs/algorithms.md §2.3 property 5).
MatX window_inverse(const MatX& window, int start) {
  Eigen::LLT<MatX> llt(window);
  if (llt.info() != Eigen::Success) {
    throw std::domain_error("band_inverse: window at " + std::to_string(start) + " is not positive definite");
  }
  return llt.solve(MatX::Identity(window.rows(), window.cols()));
}

// Z[start:start+count−1] += sign · W (lower triangle; the window lies inside Z's band).
void accumulate_window(BandMatrix& z, int start, const MatX& w, double sign) {
  MatX& s = z.storage();
  const int count = static_cast<int>(w.rows());
  for (int c = 0; c < count; ++c) {
    s.col(start + c).head(count - c) += sign * w.col(c).tail(count - c);
  }
}

// In-place rank-1 update of a lower Cholesky factor: G Gᵀ + x xᵀ.
void cholesky_rank1_update(Eigen::Ref<MatX> g, Eigen::Ref<VecX> x) {
  const int p = static_cast<int>(g.rows());
  for (int k = 0; k < p; ++k) {
    const double r = std::hypot(g(k, k), x(k));
    const double c = r / g(k, k);
    const double s = x(k) / g(k, k);
    g(k, k) = r;
    for (int i = k + 1; i < p; ++i) {
      g(i, k) = (g(i, k) + s * x(i)) / c;
      x(i) = c * x(i) - s * g(i, k);
    }
  }
}

}  // namespace

// Khan et al. Alg. 1 with the inclusive windows (docs/algorithms.md §2.3), 0-based.
BandMatrix band_inverse_windows(const BandMatrix& a, int bandwidth) {
  const int n = a.size();
  check_bandwidth(n, bandwidth);
  BandMatrix z(n, bandwidth);
  for (int l = 0; l + bandwidth < n; ++l) {  // (L+1)×(L+1) windows, l = 1 … n−L in the paper
    accumulate_window(z, l, window_inverse(a.principal_block(l, bandwidth + 1), l), 1.0);
  }
  if (bandwidth > 0) {
    for (int l = 1; l + bandwidth < n; ++l) {  // L×L overlaps, l = 2 … n−L in the paper
      accumulate_window(z, l, window_inverse(a.principal_block(l, bandwidth), l), -1.0);
    }
  }
  return z;
}

// Z = Σ_i r_i r_iᵀ / D_i with r_i = e_i − (regression of variable i on the ≤ L variables before it):
// the banded information of the maximum-determinant completion. G is the Cholesky factor of
// A[s:i−1] (s = max(0, i−L)); appending row i and dropping row s−1 keeps it current in O(L²).
BandMatrix band_inverse_sliding(const BandMatrix& a, int bandwidth) {
  const int n = a.size();
  check_bandwidth(n, bandwidth);
  BandMatrix z(n, bandwidth);
  MatX& zs = z.storage();
  MatX g = MatX::Zero(bandwidth + 1, bandwidth + 1);
  MatX shifted = MatX::Zero(bandwidth + 1, bandwidth + 1);
  VecX r(bandwidth + 1);
  VecX gi(bandwidth + 1);
  int start = 0;
  for (int i = 0; i < n; ++i) {
    const int m = i - start;  // previous variables in the window
    for (int p = 0; p < m; ++p) gi(p) = a(start + p, i);
    const auto factor = g.topLeftCorner(m, m).triangularView<Eigen::Lower>();
    factor.solveInPlace(gi.head(m));                      // G g_i = A[s:i−1, i]
    const double d = a(i, i) - gi.head(m).squaredNorm();  // conditional variance D_i
    if (!(d > 0.0) || !std::isfinite(d)) {
      throw std::domain_error("band_inverse: window ending at " + std::to_string(i) +
                              " is not positive definite");
    }
    r.head(m) = -gi.head(m);
    factor.transpose().solveInPlace(r.head(m));  // b_i = G⁻ᵀ g_i
    r(m) = 1.0;
    for (int c = 0; c <= m; ++c) {
      zs.col(start + c).head(m + 1 - c) += r.segment(c, m + 1 - c) * (r(c) / d);
    }
    g.row(m).head(m) = gi.head(m).transpose();
    g(m, m) = std::sqrt(d);
    if (m + 1 > bandwidth) {  // window full: drop variable `start`
      shifted.topLeftCorner(m, m) = g.block(1, 1, m, m);
      if (m > 0) {
        gi.head(m) = g.col(0).segment(1, m);
        cholesky_rank1_update(shifted.topLeftCorner(m, m), gi.head(m));
      }
      std::swap(g, shifted);
      ++start;
    }
  }
  return z;
}

BandMatrix band_inverse(const BandMatrix& a, int bandwidth, BandInversionMethod method) {
  return method == BandInversionMethod::kWindows ? band_inverse_windows(a, bandwidth)
                                                 : band_inverse_sliding(a, bandwidth);
}

MatX band_inverse(const MatX& a, int bandwidth, BandInversionMethod method) {
  return band_inverse(BandMatrix::from_dense(a, bandwidth), bandwidth, method).to_dense();
}

}  // namespace swarmloc::estimators::centralized
