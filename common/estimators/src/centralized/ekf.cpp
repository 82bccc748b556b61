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

// ---- EKF, Khan et al. eqs. (10)–(12) with, D coordinates per agent ----
template <int D>
class Ekf final : public CentralizedFilterOf<D> {
  using Base = CentralizedFilterOf<D>;
  using Base::index;
  using Base::initial_cov_;
  using Base::labels_;
  using Base::num_agents;
  using Base::process_var_;
  using Base::x_;
  using typename Base::Mat;
  using typename Base::Vec;

 public:
  Ekf(const VecX& mean, const std::vector<Mat>& cov, const CentralizedFilterParams& params)
      : Base(mean, cov, params) {}
  [[nodiscard]] std::string_view name() const override { return "ekf"; }

  void step(const CentralizedMeasurements& meas) override {
    const int n = static_cast<int>(x_.size());
    MatX p;
    if (this->predict_mean()) {
      p = std::move(m_);
      p.diagonal().array() += process_var_;  // (10)
    } else {
      p = MatX::Zero(n, n);  // P_0 = Σ_0
      for (int a = 0; a < num_agents(); ++a)
        p.block<D, D>(index(a), index(a)) = initial_cov_[static_cast<std::size_t>(a)];
    }
    this->check_innovations(meas, [&](int li, int lj, const Vec& u) {
      const Mat difference = p.block<D, D>(D * li, D * li) + p.block<D, D>(D * lj, D * lj) -
                             p.block<D, D>(D * li, D * lj) - p.block<D, D>(D * lj, D * li);
      return u.dot(difference * u);
    });
    MatX y = filter_kernels::spd_inverse(p);
    int bandwidth = 0;
    const VecX b = filter_kernels::assemble<D>(
        meas, x_, labels_,
        [&](int bi, int bj, const Mat& block) {
          y.block<D, D>(D * bi, D * bj) += block;
          if (bi != bj) y.block<D, D>(D * bj, D * bi) += block.transpose();
          bandwidth = std::max(bandwidth, filter_kernels::block_bandwidth<D>(bi, bj, block));
        },
        filter_kernels::kKeepAllEdges);
    m_ = filter_kernels::spd_inverse(y);  // (11)
    x_ += m_ * b;                         // (12)
    this->last_measurement_bandwidth_ = bandwidth;
    this->last_truncated_entries_ = 0;
    this->store_velocity(meas);
  }

  [[nodiscard]] MatX covariance_dense() const override {
    return filter_kernels::unpermute_dense<D>(m_, labels_);
  }

 private:
  [[nodiscard]] Mat agent_covariance(int agent) const override {
    return m_.block<D, D>(index(agent), index(agent));
  }

  MatX m_;
};

}  // namespace

template <int D>
std::unique_ptr<CentralizedFilter> filter_kernels::make_ekf(const VecX& mean, const std::vector<Mat<D>>& cov,
                                                            const CentralizedFilterParams& params) {
  return std::make_unique<Ekf<D>>(mean, cov, params);
}
template std::unique_ptr<CentralizedFilter> filter_kernels::make_ekf<2>(const VecX&, const std::vector<Mat2>&,
                                                                        const CentralizedFilterParams&);
template std::unique_ptr<CentralizedFilter> filter_kernels::make_ekf<3>(const VecX&, const std::vector<Mat3>&,
                                                                        const CentralizedFilterParams&);

}  // namespace swarmloc::estimators::centralized
