// LB-EKF (Khan et al. Alg. 2, banded covariance) behind CentralizedFilter.
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

// ---- LB-EKF, Khan et al. Alg. 2 (banded covariance; docs/algorithms.md §2.4), D coordinates per agent ----
template <int D>
class LbEkf final : public CentralizedFilterOf<D> {
  using Base = CentralizedFilterOf<D>;
  using Base::index;
  using Base::initial_cov_;
  using Base::labels_;
  using Base::process_var_;
  using Base::x_;
  using typename Base::Mat;
  using typename Base::Vec;

 public:
  LbEkf(const VecX& mean, const std::vector<Mat>& cov, const CentralizedFilterParams& params)
      : Base(mean, cov, params),
        bandwidth_(filter_kernels::clamp_bandwidth<D>(params.bandwidth, cov.size())),
        method_(params.inversion) {}
  [[nodiscard]] std::string_view name() const override { return "lb-ekf"; }

  void step(const CentralizedMeasurements& meas) override {
    BandMatrix p;
    if (this->predict_mean()) {
      p = std::move(m_);
      p.add_diagonal(process_var_);  // line 3: P_k = M̆_{k−1} + σ_p I
    } else {
      p = filter_kernels::initial_band<D>(initial_cov_, labels_, bandwidth_);  // P_0 = Σ_0
    }
    this->check_innovations(meas, [&](int li, int lj, const Vec& u) {  // own blocks only (the band's edge)
      return u.dot((filter_kernels::band_block<D>(p, D * li) + filter_kernels::band_block<D>(p, D * lj)) * u);
    });
    BandMatrix y = band_inverse(p, bandwidth_, method_);  // line 3: P̆_k⁻¹ = BandInv_L(P_k)
    filter_kernels::BandSink<D> sink{&y};
    const VecX b =
        filter_kernels::assemble<D>(meas, x_, labels_, sink,
                                    filter_kernels::kKeepAllEdges);  // line 4: Y_k = P̆⁻¹ + band(S_k)
    m_ = band_inverse(y, bandwidth_, method_);                       // line 4: M̆_k = BandInv_L(Y_k)
    x_ += m_.multiply(b);                                            // line 5, O(nL)
    this->last_measurement_bandwidth_ = sink.bandwidth;
    this->last_truncated_entries_ = sink.truncated;
    this->store_velocity(meas);
  }

  [[nodiscard]] MatX covariance_dense() const override {
    return filter_kernels::unpermute_dense<D>(m_.to_dense(), labels_);
  }

 private:
  [[nodiscard]] Mat agent_covariance(int agent) const override {
    return filter_kernels::band_block<D>(m_, index(agent));
  }

  int bandwidth_;
  BandInversionMethod method_;
  BandMatrix m_;
};

}  // namespace

template <int D>
std::unique_ptr<CentralizedFilter> filter_kernels::make_lb_ekf(const VecX& mean,
                                                               const std::vector<Mat<D>>& cov,
                                                               const CentralizedFilterParams& params) {
  return std::make_unique<LbEkf<D>>(mean, cov, params);
}
template std::unique_ptr<CentralizedFilter> filter_kernels::make_lb_ekf<2>(const VecX&,
                                                                           const std::vector<Mat2>&,
                                                                           const CentralizedFilterParams&);
template std::unique_ptr<CentralizedFilter> filter_kernels::make_lb_ekf<3>(const VecX&,
                                                                           const std::vector<Mat3>&,
                                                                           const CentralizedFilterParams&);

}  // namespace swarmloc::estimators::centralized
