#pragma once
// What the centralized filters (src/centralized/ekf.cpp, lb_ekf.cpp, lb_ekf_i.cpp) and their base
// (centralized_filter.cpp) share: the measurement assembly of docs/algorithms.md §2.1 and the band helpers.
#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "swarmloc/estimators/centralized/band_inversion.hpp"
#include "swarmloc/estimators/centralized/band_matrix.hpp"
#include "swarmloc/estimators/centralized/centralized_filter.hpp"

namespace swarmloc::estimators::centralized::filter_kernels {

inline constexpr double kMinRange = 1e-9;  // docs/algorithms.md §1.1 guard

// docs/algorithms.md §2.1: S_k and b_k without building H. `add_block(bi, bj, B)` means S[bi,bj] += B
// (and S[bj,bi] += Bᵀ when bi != bj); block indices are internal (relabeled) agent indices.
// `keep_edge(li, lj, S[li,lj])` may reject a range edge before any of its terms are added.
template <typename AddBlock, typename KeepEdge>
inline VecX assemble(const CentralizedMeasurements& meas, const VecX& x, const std::vector<int>& labels,
                     AddBlock&& add_block, KeepEdge&& keep_edge) {
  VecX b = VecX::Zero(x.size());
  const auto label = [&](int agent) {
    if (agent < 0 || static_cast<std::size_t>(agent) >= labels.size()) {
      throw std::invalid_argument("centralized measurements: agent " + std::to_string(agent) +
                                  " out of range");
    }
    return labels[static_cast<std::size_t>(agent)];
  };
  const Mat2 beacon_info = Mat2::Identity() / meas.beacon_var;
  for (const auto& [agent, fix] : meas.beacon_fixes) {
    const int l = label(agent);
    add_block(l, l, beacon_info);
    b.segment<2>(2 * l) += (fix - x.segment<2>(2 * l)) / meas.beacon_var;
  }
  for (const auto& edge : meas.ranges) {
    const int li = label(edge.i);
    const int lj = label(edge.j);
    if (li == lj) continue;
    const Vec2 delta = x.segment<2>(2 * li) - x.segment<2>(2 * lj);
    const double rho = delta.norm();
    if (rho < kMinRange) continue;
    const Vec2 u = delta / rho;  // ∂φ/∂x_i = uᵀ, ∂φ/∂x_j = −uᵀ (docs/algorithms.md §1.1)
    const Mat2 uu = u * u.transpose() / meas.range_var;
    if (!keep_edge(li, lj, Mat2(-uu))) continue;
    add_block(li, li, uu);
    add_block(lj, lj, uu);
    add_block(li, lj, -uu);
    const Vec2 bu = u * ((edge.range_m - rho) / meas.range_var);
    b.segment<2>(2 * li) += bu;
    b.segment<2>(2 * lj) -= bu;
  }
  return b;
}

inline constexpr auto kKeepAllEdges = [](int, int, const Mat2&) { return true; };

// Largest scalar |row − col| among the nonzero entries of S[bi,bj] (lower triangle for bi = bj).
inline int block_bandwidth(int bi, int bj, const Mat2& block) {
  int bandwidth = 0;
  for (int c = 0; c < 2; ++c) {
    for (int r = 0; r < 2; ++r) {
      if ((bi == bj && r < c) || block(r, c) == 0.0) continue;
      bandwidth = std::max(bandwidth, std::abs(2 * bi + r - 2 * bj - c));
    }
  }
  return bandwidth;
}

struct BandSink {
  BandMatrix* band;
  int truncated = 0;
  int bandwidth = 0;  // Bandwidth(S) in scalar indices
  void operator()(int bi, int bj, const Mat2& block) {
    for (int c = 0; c < 2; ++c) {
      for (int r = 0; r < 2; ++r) {
        const int row = 2 * bi + r;
        const int col = 2 * bj + c;
        if (bi == bj && r < c) continue;  // diagonal block: lower triangle only
        if (block(r, c) == 0.0) continue;
        bandwidth = std::max(bandwidth, std::abs(row - col));
        if (band->in_band(row, col)) {
          band->ref(row, col) += block(r, c);
        } else {
          ++truncated;
        }
      }
    }
  }
};

// Dense SPD inverse via Cholesky.
inline MatX spd_inverse(const MatX& a) {
  Eigen::LLT<MatX> llt(a);
  if (llt.info() != Eigen::Success) throw std::domain_error("EKF: matrix is not positive definite");
  return llt.solve(MatX::Identity(a.rows(), a.cols()));
}

inline MatX unpermute_dense(const MatX& internal, const std::vector<int>& labels) {
  const int n = static_cast<int>(internal.rows());
  MatX out(n, n);
  const int agents = static_cast<int>(labels.size());
  for (int a = 0; a < agents; ++a) {
    for (int b = 0; b < agents; ++b) {
      out.block<2, 2>(2 * a, 2 * b) = internal.block<2, 2>(2 * labels[static_cast<std::size_t>(a)],
                                                           2 * labels[static_cast<std::size_t>(b)]);
    }
  }
  return out;
}

inline int clamp_bandwidth(int bandwidth, std::size_t agents) {
  const int n = 2 * static_cast<int>(agents);
  if (bandwidth < 0)
    throw std::invalid_argument("centralized filter: bandwidth " + std::to_string(bandwidth) + " < 0");
  return std::min(bandwidth, n - 1);
}

// Σ_0 (block diagonal) in band storage; with L = 0 its off-diagonal entries are dropped.
inline BandMatrix initial_band(const std::vector<Mat2>& cov, const std::vector<int>& labels, int bandwidth) {
  BandMatrix p(2 * static_cast<int>(cov.size()), bandwidth);
  for (std::size_t a = 0; a < cov.size(); ++a) {
    const int i = 2 * labels[a];
    p.ref(i, i) = cov[a](0, 0);
    p.ref(i + 1, i + 1) = cov[a](1, 1);
    if (bandwidth >= 1) p.ref(i + 1, i) = cov[a](1, 0);
  }
  return p;
}

inline Mat2 band_block(const BandMatrix& band, int i) {
  Mat2 block;
  block << band(i, i), band(i, i + 1), band(i + 1, i), band(i + 1, i + 1);
  return block;
}

// The filters, one file each.
std::unique_ptr<CentralizedFilter> make_ekf(const VecX& mean, const std::vector<Mat2>& cov,
                                            const CentralizedFilterParams& params);
std::unique_ptr<CentralizedFilter> make_lb_ekf(const VecX& mean, const std::vector<Mat2>& cov,
                                               const CentralizedFilterParams& params);
std::unique_ptr<CentralizedFilter> make_lb_ekf_i(const VecX& mean, const std::vector<Mat2>& cov,
                                                 const CentralizedFilterParams& params);

}  // namespace swarmloc::estimators::centralized::filter_kernels
