#pragma once
// What the centralized filters (src/centralized/ekf.cpp, lb_ekf.cpp, lb_ekf_i.cpp) and their base
// (centralized_filter.cpp) share: the base in D = 2 or 3 dimensions, the measurement assembly of
// docs/algorithms.md §2.1 and the band helpers. Every kernel is a template on D; D = 2 runs the fixed-size
// 2×2 operations, in the same order, that the planar filters always ran.
#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "swarmloc/estimators/centralized/band_inversion.hpp"
#include "swarmloc/estimators/centralized/band_matrix.hpp"
#include "swarmloc/estimators/centralized/centralized_filter.hpp"

namespace swarmloc::estimators::centralized {

/// The base of the filters in D dimensions: the initial covariance, the prediction of the mean and the
/// self-checks, all with D coordinates per agent (docs/algorithms.md §2.1, §1.6).
template <int D>
class CentralizedFilterOf : public CentralizedFilter {
  static_assert(D == 2 || D == 3);

 public:
  using Vec = Eigen::Matrix<double, D, 1>;
  using Mat = Eigen::Matrix<double, D, D>;

  [[nodiscard]] Mat2 covariance_block(int agent) const final {
    if constexpr (D == 2) {
      return agent_covariance(agent);
    } else {
      return agent_covariance(agent).template topLeftCorner<2, 2>();
    }
  }
  [[nodiscard]] MatX covariance_block_full(int agent) const final { return agent_covariance(agent); }

 protected:
  /// initial_mean: x̂(0), D·N, original labels. initial_cov: Σ_0 blocks (Assumption 3), one per agent.
  CentralizedFilterOf(const VecX& initial_mean, const std::vector<Mat>& initial_cov,
                      const CentralizedFilterParams& params);
  /// The D×D diagonal block of the filter's covariance for `agent` (original label).
  [[nodiscard]] virtual Mat agent_covariance(int agent) const = 0;

  /// k >= 1: x̂⁻ = x̂⁺ + v(k−1). Returns true if this is a prediction step (k >= 1).
  bool predict_mean();
  /// Keeps v(k) for the next prediction (3-D: it moves x and y only) and counts the step.
  void store_velocity(const CentralizedMeasurements& measurements);
  using ProjectedVariance = std::function<double(int li, int lj, const Vec& u)>;
  /// Call with the predicted mean in x_, before the update: adds every range edge's innovation
  /// ν = y_ij − ‖x̂_i − x̂_j‖ over s = σ_r² + projected_variance(li, lj, u) to both endpoints' self-checks and
  /// closes their step. projected_variance gives uᵀ(P_ii + P_jj − P_ij − P_ji)u of the predicted covariance
  /// for internal indices li, lj and the unit vector u from x̂_j to x̂_i (a filter without the cross blocks
  /// leaves them out).
  void check_innovations(const CentralizedMeasurements& measurements,
                         const ProjectedVariance& projected_variance);

  std::vector<Mat> initial_cov_;  ///< Σ_0 blocks, original labels
  double process_var_ = 0.0;
  VecX pending_velocity_;  ///< v(k−1), internal order

 private:
  /// The disk-graph verdict of every agent at the predicted mean (docs/algorithms.md §1.6, "Graph").
  void check_graph(const ProjectedVariance& projected_variance);
  [[nodiscard]] std::size_t pair_index(int i, int j) const {
    return static_cast<std::size_t>(i) * labels_.size() + static_cast<std::size_t>(j);
  }

  double disk_radius_m_ = 0.0;
  std::vector<std::uint8_t> ranged_;  ///< N×N, original labels: the pair has been ranged
  std::vector<std::uint8_t> anchor_;  ///< has had a beacon fix
  int ranged_steps_ = 0;
};

extern template class CentralizedFilterOf<2>;
extern template class CentralizedFilterOf<3>;

namespace filter_kernels {

inline constexpr double kMinRange = 1e-9;  // docs/algorithms.md §1.1 guard

template <int D>
using Vec = Eigen::Matrix<double, D, 1>;
template <int D>
using Mat = Eigen::Matrix<double, D, D>;

// The D coordinates of beacon fix number `fix` of `meas` (3-D: its z from beacon_fix_z).
template <int D>
Vec<D> beacon_fix(const CentralizedMeasurements& meas, std::size_t fix) {
  if constexpr (D == 2) {
    return meas.beacon_fixes[fix].second;
  } else {
    const Vec2& planar = meas.beacon_fixes[fix].second;
    return {planar.x(), planar.y(), meas.beacon_fix_z[fix]};
  }
}

// docs/algorithms.md §2.1: S_k and b_k without building H. `add_block(bi, bj, B)` means S[bi,bj] += B
// (and S[bj,bi] += Bᵀ when bi != bj); block indices are internal (relabeled) agent indices.
// `keep_edge(li, lj, S[li,lj])` may reject a range edge before any of its terms are added.
template <int D, typename AddBlock, typename KeepEdge>
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
  if (D == 3 && meas.beacon_fix_z.size() != meas.beacon_fixes.size()) {
    throw std::invalid_argument("centralized measurements: beacon_fix_z has " +
                                std::to_string(meas.beacon_fix_z.size()) + " entries, expected " +
                                std::to_string(meas.beacon_fixes.size()));
  }
  const Mat<D> beacon_info = Mat<D>::Identity() / meas.beacon_var;
  for (std::size_t fix = 0; fix < meas.beacon_fixes.size(); ++fix) {
    const int l = label(meas.beacon_fixes[fix].first);
    add_block(l, l, beacon_info);
    b.template segment<D>(D * l) +=
        (beacon_fix<D>(meas, fix) - x.template segment<D>(D * l)) / meas.beacon_var;
  }
  for (const auto& edge : meas.ranges) {
    const int li = label(edge.i);
    const int lj = label(edge.j);
    if (li == lj) continue;
    const Vec<D> delta = x.template segment<D>(D * li) - x.template segment<D>(D * lj);
    const double rho = delta.norm();
    if (rho < kMinRange) continue;
    const Vec<D> u = delta / rho;  // ∂φ/∂x_i = uᵀ, ∂φ/∂x_j = −uᵀ (docs/algorithms.md §1.1), in D
    const Mat<D> uu = u * u.transpose() / meas.range_var;
    if (!keep_edge(li, lj, Mat<D>(-uu))) continue;
    add_block(li, li, uu);
    add_block(lj, lj, uu);
    add_block(li, lj, -uu);
    const Vec<D> bu = u * ((edge.range_m - rho) / meas.range_var);
    b.template segment<D>(D * li) += bu;
    b.template segment<D>(D * lj) -= bu;
  }
  return b;
}

inline constexpr auto kKeepAllEdges = [](int, int, const auto&) { return true; };

// Largest scalar |row − col| among the nonzero entries of S[bi,bj] (lower triangle for bi = bj).
template <int D>
inline int block_bandwidth(int bi, int bj, const Mat<D>& block) {
  int bandwidth = 0;
  for (int c = 0; c < D; ++c) {
    for (int r = 0; r < D; ++r) {
      if ((bi == bj && r < c) || block(r, c) == 0.0) continue;
      bandwidth = std::max(bandwidth, std::abs(D * bi + r - D * bj - c));
    }
  }
  return bandwidth;
}

template <int D>
struct BandSink {
  BandMatrix* band;
  int truncated = 0;
  int bandwidth = 0;  // Bandwidth(S) in scalar indices
  void operator()(int bi, int bj, const Mat<D>& block) {
    for (int c = 0; c < D; ++c) {
      for (int r = 0; r < D; ++r) {
        const int row = D * bi + r;
        const int col = D * bj + c;
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

template <int D>
inline MatX unpermute_dense(const MatX& internal, const std::vector<int>& labels) {
  const int n = static_cast<int>(internal.rows());
  MatX out(n, n);
  const int agents = static_cast<int>(labels.size());
  for (int a = 0; a < agents; ++a) {
    for (int b = 0; b < agents; ++b) {
      out.block<D, D>(D * a, D * b) = internal.block<D, D>(D * labels[static_cast<std::size_t>(a)],
                                                           D * labels[static_cast<std::size_t>(b)]);
    }
  }
  return out;
}

template <int D>
inline int clamp_bandwidth(int bandwidth, std::size_t agents) {
  const int n = D * static_cast<int>(agents);
  if (bandwidth < 0)
    throw std::invalid_argument("centralized filter: bandwidth " + std::to_string(bandwidth) + " < 0");
  return std::min(bandwidth, n - 1);
}

// Σ_0 (block diagonal) in band storage; entries of a block farther than L from the diagonal are dropped.
template <int D>
inline BandMatrix initial_band(const std::vector<Mat<D>>& cov, const std::vector<int>& labels,
                               int bandwidth) {
  BandMatrix p(D * static_cast<int>(cov.size()), bandwidth);
  for (std::size_t a = 0; a < cov.size(); ++a) {
    const int i = D * labels[a];
    for (int c = 0; c < D; ++c) {
      for (int r = c; r < D; ++r) {
        if (r - c <= bandwidth) p.ref(i + r, i + c) = cov[a](r, c);
      }
    }
  }
  return p;
}

template <int D>
inline Mat<D> band_block(const BandMatrix& band, int i) {
  Mat<D> block;
  for (int r = 0; r < D; ++r) {
    for (int c = 0; c < D; ++c) block(r, c) = band(i + r, i + c);
  }
  return block;
}

// The filters, one file each, instantiated for D = 2 and 3.
template <int D>
std::unique_ptr<CentralizedFilter> make_ekf(const VecX& mean, const std::vector<Mat<D>>& cov,
                                            const CentralizedFilterParams& params);
template <int D>
std::unique_ptr<CentralizedFilter> make_lb_ekf(const VecX& mean, const std::vector<Mat<D>>& cov,
                                               const CentralizedFilterParams& params);
template <int D>
std::unique_ptr<CentralizedFilter> make_lb_ekf_i(const VecX& mean, const std::vector<Mat<D>>& cov,
                                                 const CentralizedFilterParams& params);

}  // namespace filter_kernels
}  // namespace swarmloc::estimators::centralized
