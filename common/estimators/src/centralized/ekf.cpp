// The centralized EKF (Khan et al. eqs. (10)–(12) with) behind CentralizedFilter.
#include <algorithm>
#include <cmath>
#include <memory>
#include <string_view>
#include <utility>
#include <vector>

#include "centralized/filter_kernels.hpp"
#include "swarmloc/estimators/centralized/centralized_filter.hpp"

namespace swarmloc::estimators::centralized {
namespace {

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
    MatX y = filter_kernels::spd_inverse(p);
    int bandwidth = 0;
    const VecX b = filter_kernels::assemble(
        meas, x_, labels_,
        [&](int bi, int bj, const Mat2& block) {
          y.block<2, 2>(2 * bi, 2 * bj) += block;
          if (bi != bj) y.block<2, 2>(2 * bj, 2 * bi) += block.transpose();
          bandwidth = std::max(bandwidth, filter_kernels::block_bandwidth(bi, bj, block));
        },
        filter_kernels::kKeepAllEdges);
    m_ = filter_kernels::spd_inverse(y);  // (11)
    x_ += m_ * b;                         // (12)
    last_measurement_bandwidth_ = bandwidth;
    last_truncated_entries_ = 0;
    store_velocity(meas);
  }

  [[nodiscard]] Mat2 covariance_block(int agent) const override {
    return m_.block<2, 2>(index(agent), index(agent));
  }
  [[nodiscard]] MatX covariance_dense() const override {
    return filter_kernels::unpermute_dense(m_, labels_);
  }

 private:
  MatX m_;
};

}  // namespace

std::unique_ptr<CentralizedFilter> filter_kernels::make_ekf(const VecX& mean, const std::vector<Mat2>& cov,
                                                            const CentralizedFilterParams& params) {
  return std::make_unique<Ekf>(mean, cov, params);
}

}  // namespace swarmloc::estimators::centralized
