#include "swarmloc/estimators/centralized/centralized_filter.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "swarmloc/estimators/centralized/relabeling.hpp"

namespace swarmloc::estimators::centralized {
namespace {

constexpr double kMinRange = 1e-9;  // docs/algorithms.md §1.1 guard
// The disk-graph test (docs/algorithms.md §1.6): it waits for every pair in range to have been ranged, and a
// pair must be placed this far inside the radius, and this many of its distance's σ, to count.
constexpr int kGraphPatienceSteps = 10;
constexpr double kGraphMarginFraction = 0.05;
constexpr double kGraphFalseAlarm = 1e-4;

// docs/algorithms.md §2.1: S_k and b_k without building H. `add_block(bi, bj, B)` means S[bi,bj] += B
// (and S[bj,bi] += Bᵀ when bi != bj); block indices are internal (relabeled) agent indices.
// `keep_edge(li, lj, S[li,lj])` may reject a range edge before any of its terms are added.
template <typename AddBlock, typename KeepEdge>
VecX assemble(const CentralizedMeasurements& meas, const VecX& x, const std::vector<int>& labels,
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

constexpr auto kKeepAllEdges = [](int, int, const Mat2&) { return true; };

// Largest scalar |row − col| among the nonzero entries of S[bi,bj] (lower triangle for bi = bj).
int block_bandwidth(int bi, int bj, const Mat2& block) {
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

void check_setup(const VecX& mean, const std::vector<Mat2>& cov, const std::vector<int>& labels) {
  const auto n = cov.size();
  if (static_cast<std::size_t>(mean.size()) != 2 * n) {
    throw std::invalid_argument("centralized filter: initial_mean has " + std::to_string(mean.size()) +
                                " entries, expected 2 × " + std::to_string(n));
  }
  if (!labels.empty() && labels.size() != n) {
    throw std::invalid_argument("centralized filter: labels has " + std::to_string(labels.size()) +
                                " entries, expected " + std::to_string(n));
  }
  if (n == 0) throw std::invalid_argument("centralized filter: no agents");
}

// Dense SPD inverse via Cholesky.
MatX spd_inverse(const MatX& a) {
  Eigen::LLT<MatX> llt(a);
  if (llt.info() != Eigen::Success) throw std::domain_error("EKF: matrix is not positive definite");
  return llt.solve(MatX::Identity(a.rows(), a.cols()));
}

MatX unpermute_dense(const MatX& internal, const std::vector<int>& labels) {
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

// ---- EKF, Khan et al. eqs. (10)–(12) with [A-2] ----
class Ekf final : public CentralizedFilter {
 public:
  Ekf(const VecX& mean, const std::vector<Mat2>& cov, const CentralizedFilterParams& params)
      : CentralizedFilter(mean, cov, params) {}
  [[nodiscard]] std::string_view name() const override { return "ekf"; }

  void step(const CentralizedMeasurements& meas) override {
    const int n = static_cast<int>(x_.size());
    MatX p;
    if (predict_mean()) {
      p = std::move(m_);
      p.diagonal().array() += process_var_;  // (10)
    } else {
      p = MatX::Zero(n, n);  // P_0 = Σ_0
      for (int a = 0; a < num_agents(); ++a)
        p.block<2, 2>(index(a), index(a)) = initial_cov_[static_cast<std::size_t>(a)];
    }
    check_innovations(meas, [&](int li, int lj, const Vec2& u) {
      const Mat2 difference = p.block<2, 2>(2 * li, 2 * li) + p.block<2, 2>(2 * lj, 2 * lj) -
                              p.block<2, 2>(2 * li, 2 * lj) - p.block<2, 2>(2 * lj, 2 * li);
      return u.dot(difference * u);
    });
    MatX y = spd_inverse(p);
    int bandwidth = 0;
    const VecX b = assemble(
        meas, x_, labels_,
        [&](int bi, int bj, const Mat2& block) {
          y.block<2, 2>(2 * bi, 2 * bj) += block;
          if (bi != bj) y.block<2, 2>(2 * bj, 2 * bi) += block.transpose();
          bandwidth = std::max(bandwidth, block_bandwidth(bi, bj, block));
        },
        kKeepAllEdges);
    m_ = spd_inverse(y);  // (11)
    x_ += m_ * b;         // (12)
    last_measurement_bandwidth_ = bandwidth;
    last_truncated_entries_ = 0;
    store_velocity(meas);
  }

  [[nodiscard]] Mat2 covariance_block(int agent) const override {
    return m_.block<2, 2>(index(agent), index(agent));
  }
  [[nodiscard]] MatX covariance_dense() const override { return unpermute_dense(m_, labels_); }

 private:
  MatX m_;
};

int clamp_bandwidth(int bandwidth, std::size_t agents) {
  const int n = 2 * static_cast<int>(agents);
  if (bandwidth < 0)
    throw std::invalid_argument("centralized filter: bandwidth " + std::to_string(bandwidth) + " < 0");
  return std::min(bandwidth, n - 1);
}

// Σ_0 (block diagonal) in band storage; with L = 0 its off-diagonal entries are dropped.
BandMatrix initial_band(const std::vector<Mat2>& cov, const std::vector<int>& labels, int bandwidth) {
  BandMatrix p(2 * static_cast<int>(cov.size()), bandwidth);
  for (std::size_t a = 0; a < cov.size(); ++a) {
    const int i = 2 * labels[a];
    p.ref(i, i) = cov[a](0, 0);
    p.ref(i + 1, i + 1) = cov[a](1, 1);
    if (bandwidth >= 1) p.ref(i + 1, i) = cov[a](1, 0);
  }
  return p;
}

Mat2 band_block(const BandMatrix& band, int i) {
  Mat2 block;
  block << band(i, i), band(i, i + 1), band(i + 1, i), band(i + 1, i + 1);
  return block;
}

// ---- LB-EKF, Khan et al. Alg. 2 (banded covariance; docs/algorithms.md §2.4) ----
class LbEkf final : public CentralizedFilter {
 public:
  LbEkf(const VecX& mean, const std::vector<Mat2>& cov, const CentralizedFilterParams& params)
      : CentralizedFilter(mean, cov, params),
        bandwidth_(clamp_bandwidth(params.bandwidth, cov.size())),
        method_(params.inversion) {}
  [[nodiscard]] std::string_view name() const override { return "lb-ekf"; }

  void step(const CentralizedMeasurements& meas) override {
    BandMatrix p;
    if (predict_mean()) {
      p = std::move(m_);
      p.add_diagonal(process_var_);  // line 3: P_k = M̆_{k−1} + σ_p I
    } else {
      p = initial_band(initial_cov_, labels_, bandwidth_);  // P_0 = Σ_0
    }
    check_innovations(meas, [&](int li, int lj, const Vec2& u) {  // own blocks only (the band's edge)
      return u.dot((band_block(p, 2 * li) + band_block(p, 2 * lj)) * u);
    });
    BandMatrix y = band_inverse(p, bandwidth_, method_);  // line 3: P̆_k⁻¹ = BandInv_L(P_k)
    BandSink sink{&y};
    const VecX b = assemble(meas, x_, labels_, sink, kKeepAllEdges);  // line 4: Y_k = P̆⁻¹ + band(S_k)
    m_ = band_inverse(y, bandwidth_, method_);                        // line 4: M̆_k = BandInv_L(Y_k)
    x_ += m_.multiply(b);                                             // line 5, O(nL)
    last_measurement_bandwidth_ = sink.bandwidth;
    last_truncated_entries_ = sink.truncated;
    store_velocity(meas);
  }

  [[nodiscard]] Mat2 covariance_block(int agent) const override { return band_block(m_, index(agent)); }
  [[nodiscard]] MatX covariance_dense() const override { return unpermute_dense(m_.to_dense(), labels_); }

 private:
  int bandwidth_;
  BandInversionMethod method_;
  BandMatrix m_;
};

// ---- LB-EKF-I, docs/algorithms.md §2.4 [A-4] (banded information) ----
class LbEkfI final : public CentralizedFilter {
 public:
  LbEkfI(const VecX& mean, const std::vector<Mat2>& cov, const CentralizedFilterParams& params)
      : CentralizedFilter(mean, cov, params),
        bandwidth_(clamp_bandwidth(params.bandwidth, cov.size())),
        method_(params.inversion) {}
  [[nodiscard]] std::string_view name() const override { return "lb-ekf-i"; }

  void step(const CentralizedMeasurements& meas) override {
    BandMatrix p;
    if (predict_mean()) {
      p = std::move(sigma_band_);  // band(Y_{k−1}⁻¹) by Takahashi
      p.add_diagonal(process_var_);
    } else {
      p = initial_band(initial_cov_, labels_, bandwidth_);
    }
    check_innovations(meas, [&](int li, int lj, const Vec2& u) {
      return u.dot((band_block(p, 2 * li) + band_block(p, 2 * lj)) * u);
    });
    y_ = band_inverse(p, bandwidth_, method_);  // P̆_k⁻¹
    BandSink sink{&y_};
    // Keep Y_k PD: the band of S_k is not PSD when an edge's cross block straddles the band edge, so
    // an edge whose cross block does not fit entirely is left out (S and b), which is conservative.
    const auto fits = [&](int li, int lj, const Mat2& cross) {
      if (2 * std::abs(li - lj) + 1 <= bandwidth_) return true;
      sink.bandwidth = std::max(sink.bandwidth, block_bandwidth(li, lj, cross));
      sink.truncated += static_cast<int>((cross.array() != 0.0).count());
      return false;
    };
    const VecX b = assemble(meas, x_, labels_, sink, fits);
    const BandCholesky chol(y_);
    x_ += chol.solve(b);  // Y_k δ = b_k
    sigma_band_ = chol.selected_inverse();
    last_measurement_bandwidth_ = sink.bandwidth;
    last_truncated_entries_ = sink.truncated;
    store_velocity(meas);
  }

  [[nodiscard]] Mat2 covariance_block(int agent) const override {
    return band_block(sigma_band_, index(agent));
  }
  [[nodiscard]] MatX covariance_dense() const override {
    return unpermute_dense(spd_inverse(y_.to_dense()), labels_);
  }

 private:
  int bandwidth_;
  BandInversionMethod method_;
  BandMatrix y_;
  BandMatrix sigma_band_;
};

}  // namespace

MeasurementInformation assemble_measurement_information(const CentralizedMeasurements& measurements,
                                                        const VecX& linearization_point,
                                                        const std::vector<int>& labels) {
  const int n = static_cast<int>(linearization_point.size());
  const std::vector<int> l = labels.empty() ? identity_labels(n / 2) : labels;
  VecX x_internal(n);
  for (std::size_t a = 0; a < l.size(); ++a) {
    x_internal.segment<2>(2 * l[a]) = linearization_point.segment<2>(2 * static_cast<Eigen::Index>(a));
  }
  MeasurementInformation out{MatX::Zero(n, n), VecX()};
  // The measurements name original agents; map them through `l` inside assemble.
  out.vector = assemble(
      measurements, x_internal, l,
      [&](int bi, int bj, const Mat2& block) {
        out.information.block<2, 2>(2 * bi, 2 * bj) += block;
        if (bi != bj) out.information.block<2, 2>(2 * bj, 2 * bi) += block.transpose();
      },
      kKeepAllEdges);
  return out;
}

CentralizedFilter::CentralizedFilter(const VecX& initial_mean, const std::vector<Mat2>& initial_cov,
                                     const CentralizedFilterParams& params)
    : labels_(params.labels), initial_cov_(initial_cov), process_var_(params.process_var) {
  check_setup(initial_mean, initial_cov, params.labels);
  if (labels_.empty()) labels_ = identity_labels(static_cast<int>(initial_cov.size()));
  (void)inverse_labels(labels_);  // validates the permutation
  x_.resize(initial_mean.size());
  for (int a = 0; a < num_agents(); ++a) x_.segment<2>(index(a)) = initial_mean.segment<2>(2 * a);
  pending_velocity_ = VecX::Zero(initial_mean.size());
  self_checks_.resize(initial_cov.size());
  if (!(params.disk_radius_m >= 0.0))
    throw std::invalid_argument("centralized filter: disk_radius_m must be >= 0");
  disk_radius_m_ = params.disk_radius_m;
  const std::size_t n = initial_cov.size();
  anchor_.assign(n, 0);
  off_graph_.assign(n, 0);
  if (disk_radius_m_ > 0.0) ranged_.assign(n * n, 0);
}

bool CentralizedFilter::inconsistent(int agent) const {
  if (agent < 0 || agent >= num_agents()) return false;
  const auto a = static_cast<std::size_t>(agent);
  return self_checks_[a].inconsistent() || off_graph_[a] != 0;
}

void CentralizedFilter::check_innovations(
    const CentralizedMeasurements& measurements,
    const std::function<double(int li, int lj, const Vec2& u)>& projected_variance) {
  const int n = num_agents();
  for (const auto& edge : measurements.ranges) {
    if (edge.i < 0 || edge.i >= n || edge.j < 0 || edge.j >= n || edge.i == edge.j) continue;
    const int li = labels_[static_cast<std::size_t>(edge.i)];
    const int lj = labels_[static_cast<std::size_t>(edge.j)];
    const Vec2 delta = x_.segment<2>(2 * li) - x_.segment<2>(2 * lj);
    const double rho = delta.norm();
    if (rho < kMinRange) continue;  // no direction (docs/algorithms.md §1.1)
    const double variance = measurements.range_var + projected_variance(li, lj, Vec2(delta / rho));
    self_checks_[static_cast<std::size_t>(edge.i)].add(edge.range_m - rho, variance);
    self_checks_[static_cast<std::size_t>(edge.j)].add(edge.range_m - rho, variance);
    if (!ranged_.empty()) ranged_[pair_index(edge.i, edge.j)] = ranged_[pair_index(edge.j, edge.i)] = 1;
  }
  for (auto& check : self_checks_) check.end_step();
  for (const auto& [agent, fix] : measurements.beacon_fixes) {
    if (agent >= 0 && agent < n) anchor_[static_cast<std::size_t>(agent)] = 1;
  }
  if (!measurements.ranges.empty()) ++ranged_steps_;
  check_graph(projected_variance);
}

void CentralizedFilter::check_graph(const ProjectedVariance& projected_variance) {
  std::fill(off_graph_.begin(), off_graph_.end(), 0);
  if (ranged_.empty() || ranged_steps_ < kGraphPatienceSteps) return;
  const double floor_m = kGraphMarginFraction * disk_radius_m_;
  const double sigmas = standard_normal_upper_quantile(kGraphFalseAlarm);
  const int n = num_agents();
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      const auto ai = static_cast<std::size_t>(i);
      const auto aj = static_cast<std::size_t>(j);
      if (ranged_[pair_index(i, j)] != 0 || (anchor_[ai] != 0 && anchor_[aj] != 0)) continue;
      const int li = labels_[ai];
      const int lj = labels_[aj];
      const Vec2 delta = x_.segment<2>(2 * li) - x_.segment<2>(2 * lj);
      const double inside_m = disk_radius_m_ - delta.norm();
      if (inside_m <= floor_m) continue;
      const Vec2 u = delta.norm() > kMinRange ? Vec2(delta.normalized()) : Vec2(Vec2::UnitX());
      const double spread_m = std::sqrt(std::max(0.0, projected_variance(li, lj, u)));
      if (!(inside_m > sigmas * spread_m)) continue;
      // Never ranged, yet placed well within range: one of the two is wrong (a flip or fold that fits
      // every range it has). Both are flagged, as the residual test flags both ends of a bad edge.
      if (anchor_[ai] == 0) off_graph_[ai] = 1;
      if (anchor_[aj] == 0) off_graph_[aj] = 1;
    }
  }
}

VecX CentralizedFilter::mean() const {
  VecX out(x_.size());
  for (int a = 0; a < num_agents(); ++a) out.segment<2>(2 * a) = x_.segment<2>(index(a));
  return out;
}

Vec2 CentralizedFilter::agent_mean(int agent) const { return x_.segment<2>(index(agent)); }

bool CentralizedFilter::predict_mean() {
  if (steps_done_ == 0) return false;
  x_ += pending_velocity_;  // (12): x̂_{k}⁻ = x̂_{k−1}⁺ + v(k−1)
  return true;
}

void CentralizedFilter::store_velocity(const CentralizedMeasurements& measurements) {
  pending_velocity_.setZero();
  if (!measurements.velocity_inputs.empty()) {
    if (static_cast<int>(measurements.velocity_inputs.size()) != num_agents()) {
      throw std::invalid_argument("centralized measurements: velocity_inputs has " +
                                  std::to_string(measurements.velocity_inputs.size()) +
                                  " entries, expected " + std::to_string(num_agents()));
    }
    for (int a = 0; a < num_agents(); ++a) {
      pending_velocity_.segment<2>(index(a)) = measurements.velocity_inputs[static_cast<std::size_t>(a)];
    }
  }
  ++steps_done_;
}

std::unique_ptr<CentralizedFilter> make_centralized_filter(CentralizedKind kind, const VecX& initial_mean,
                                                           const std::vector<Mat2>& initial_cov,
                                                           const CentralizedFilterParams& params) {
  switch (kind) {
    case CentralizedKind::kEkf:
      return std::make_unique<Ekf>(initial_mean, initial_cov, params);
    case CentralizedKind::kLbEkf:
      return std::make_unique<LbEkf>(initial_mean, initial_cov, params);
    case CentralizedKind::kLbEkfI:
      return std::make_unique<LbEkfI>(initial_mean, initial_cov, params);
  }
  throw std::invalid_argument("make_centralized_filter: unknown kind");
}

std::string_view to_string(CentralizedKind kind) {
  switch (kind) {
    case CentralizedKind::kEkf:
      return "ekf";
    case CentralizedKind::kLbEkf:
      return "lb-ekf";
    case CentralizedKind::kLbEkfI:
      return "lb-ekf-i";
  }
  return "unknown";
}

}  // namespace swarmloc::estimators::centralized
