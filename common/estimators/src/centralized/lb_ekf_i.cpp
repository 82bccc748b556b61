// LB-EKF-I (docs/algorithms.md §2.4, banded information) behind CentralizedFilter.
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

// ---- LB-EKF-I, docs/algorithms.md §2.4 [A-4] (banded information) ----
class LbEkfI final : public CentralizedFilter {
 public:
  LbEkfI(const VecX& mean, const std::vector<Mat2>& cov, const CentralizedFilterParams& params)
      : CentralizedFilter(mean, cov, params),
        bandwidth_(filter_kernels::clamp_bandwidth(params.bandwidth, cov.size())),
        method_(params.inversion) {}
  [[nodiscard]] std::string_view name() const override { return "lb-ekf-i"; }

  void step(const CentralizedMeasurements& meas) override {
    BandMatrix p;
    if (predict_mean()) {
      p = std::move(sigma_band_);  // band(Y_{k−1}⁻¹) by Takahashi
      p.add_diagonal(process_var_);
    } else {
      p = filter_kernels::initial_band(initial_cov_, labels_, bandwidth_);
    }
    check_innovations(meas, [&](int li, int lj, const Vec2& u) {
      return u.dot((filter_kernels::band_block(p, 2 * li) + filter_kernels::band_block(p, 2 * lj)) * u);
    });
    y_ = band_inverse(p, bandwidth_, method_);  // P̆_k⁻¹
    filter_kernels::BandSink sink{&y_};
    // Keep Y_k PD: the band of S_k is not PSD when an edge's cross block straddles the band edge, so
    // an edge whose cross block does not fit entirely is left out (S and b), which is conservative.
    const auto fits = [&](int li, int lj, const Mat2& cross) {
      if (2 * std::abs(li - lj) + 1 <= bandwidth_) return true;
      sink.bandwidth = std::max(sink.bandwidth, filter_kernels::block_bandwidth(li, lj, cross));
      sink.truncated += static_cast<int>((cross.array() != 0.0).count());
      return false;
    };
    const VecX b = filter_kernels::assemble(meas, x_, labels_, sink, fits);
    const BandCholesky chol(y_);
    x_ += chol.solve(b);  // Y_k δ = b_k
    sigma_band_ = chol.selected_inverse();
    last_measurement_bandwidth_ = sink.bandwidth;
    last_truncated_entries_ = sink.truncated;
    store_velocity(meas);
  }

  [[nodiscard]] Mat2 covariance_block(int agent) const override {
    return filter_kernels::band_block(sigma_band_, index(agent));
  }
  [[nodiscard]] MatX covariance_dense() const override {
    return filter_kernels::unpermute_dense(filter_kernels::spd_inverse(y_.to_dense()), labels_);
  }

 private:
  int bandwidth_;
  BandInversionMethod method_;
  BandMatrix y_;
  BandMatrix sigma_band_;
};

}  // namespace

std::unique_ptr<CentralizedFilter> filter_kernels::make_lb_ekf_i(const VecX& mean,
                                                                 const std::vector<Mat2>& cov,
                                                                 const CentralizedFilterParams& params) {
  return std::make_unique<LbEkfI>(mean, cov, params);
}

}  // namespace swarmloc::estimators::centralized
