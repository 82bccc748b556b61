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

// ---- LB-EKF, Khan et al. Alg. 2 (banded covariance; docs/algorithms.md §2.4) ----
class LbEkf final : public CentralizedFilter {
 public:
  LbEkf(const VecX& mean, const std::vector<Mat2>& cov, const CentralizedFilterParams& params)
      : CentralizedFilter(mean, cov, params),
        bandwidth_(filter_kernels::clamp_bandwidth(params.bandwidth, cov.size())),
        method_(params.inversion) {}
  [[nodiscard]] std::string_view name() const override { return "lb-ekf"; }

  void step(const CentralizedMeasurements& meas) override {
    BandMatrix p;
    if (predict_mean()) {
      p = std::move(m_);
      p.add_diagonal(process_var_);  // line 3: P_k = M̆_{k−1} + σ_p I
    } else {
      p = filter_kernels::initial_band(initial_cov_, labels_, bandwidth_);  // P_0 = Σ_0
    }
    check_innovations(meas, [&](int li, int lj, const Vec2& u) {  // own blocks only (the band's edge)
      return u.dot((filter_kernels::band_block(p, 2 * li) + filter_kernels::band_block(p, 2 * lj)) * u);
    });
    BandMatrix y = band_inverse(p, bandwidth_, method_);  // line 3: P̆_k⁻¹ = BandInv_L(P_k)
    filter_kernels::BandSink sink{&y};
    const VecX b = filter_kernels::assemble(meas, x_, labels_, sink,
                                            filter_kernels::kKeepAllEdges);  // line 4: Y_k = P̆⁻¹ + band(S_k)
    m_ = band_inverse(y, bandwidth_, method_);                               // line 4: M̆_k = BandInv_L(Y_k)
    x_ += m_.multiply(b);                                                    // line 5, O(nL)
    last_measurement_bandwidth_ = sink.bandwidth;
    last_truncated_entries_ = sink.truncated;
    store_velocity(meas);
  }

  [[nodiscard]] Mat2 covariance_block(int agent) const override {
    return filter_kernels::band_block(m_, index(agent));
  }
  [[nodiscard]] MatX covariance_dense() const override {
    return filter_kernels::unpermute_dense(m_.to_dense(), labels_);
  }

 private:
  int bandwidth_;
  BandInversionMethod method_;
  BandMatrix m_;
};

}  // namespace

std::unique_ptr<CentralizedFilter> filter_kernels::make_lb_ekf(const VecX& mean, const std::vector<Mat2>& cov,
                                                               const CentralizedFilterParams& params) {
  return std::make_unique<LbEkf>(mean, cov, params);
}

}  // namespace swarmloc::estimators::centralized
