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

// ---- LB-EKF-I, docs/algorithms.md §2.4 [A-4] (banded information), D coordinates per agent ----
template <int D>
class LbEkfI final : public CentralizedFilterOf<D> {
  using Base = CentralizedFilterOf<D>;
  using Base::index;
  using Base::initial_cov_;
  using Base::labels_;
  using Base::process_var_;
  using Base::x_;
  using typename Base::Mat;
  using typename Base::Vec;

 public:
  LbEkfI(const VecX& mean, const std::vector<Mat>& cov, const CentralizedFilterParams& params)
      : Base(mean, cov, params),
        bandwidth_(filter_kernels::clamp_bandwidth<D>(params.bandwidth, cov.size())),
        method_(params.inversion) {}
  [[nodiscard]] std::string_view name() const override { return "lb-ekf-i"; }

  void step(const CentralizedMeasurements& meas) override {
    BandMatrix p;
    if (this->predict_mean()) {
      p = std::move(sigma_band_);  // band(Y_{k−1}⁻¹) by Takahashi
      p.add_diagonal(process_var_);
    } else {
      p = filter_kernels::initial_band<D>(initial_cov_, labels_, bandwidth_);
    }
    this->check_innovations(meas, [&](int li, int lj, const Vec& u) {
      return u.dot((filter_kernels::band_block<D>(p, D * li) + filter_kernels::band_block<D>(p, D * lj)) * u);
    });
    y_ = band_inverse(p, bandwidth_, method_);  // P̆_k⁻¹
    filter_kernels::BandSink<D> sink{&y_};
    // Keep Y_k PD: the band of S_k is not PSD when an edge's cross block straddles the band edge, so
    // an edge whose cross block does not fit entirely is left out (S and b), which is conservative. The
    // block's farthest entry from the diagonal is D·|li − lj| + D − 1 away.
    const auto fits = [&](int li, int lj, const Mat& cross) {
      if (D * std::abs(li - lj) + D - 1 <= bandwidth_) return true;
      sink.bandwidth = std::max(sink.bandwidth, filter_kernels::block_bandwidth<D>(li, lj, cross));
      sink.truncated += static_cast<int>((cross.array() != 0.0).count());
      return false;
    };
    const VecX b = filter_kernels::assemble<D>(meas, x_, labels_, sink, fits);
    const BandCholesky chol(y_);
    x_ += chol.solve(b);  // Y_k δ = b_k
    sigma_band_ = chol.selected_inverse();
    this->last_measurement_bandwidth_ = sink.bandwidth;
    this->last_truncated_entries_ = sink.truncated;
    this->store_velocity(meas);
  }

  [[nodiscard]] MatX covariance_dense() const override {
    return filter_kernels::unpermute_dense<D>(filter_kernels::spd_inverse(y_.to_dense()), labels_);
  }

 private:
  [[nodiscard]] Mat agent_covariance(int agent) const override {
    return filter_kernels::band_block<D>(sigma_band_, index(agent));
  }

  int bandwidth_;
  BandInversionMethod method_;
  BandMatrix y_;
  BandMatrix sigma_band_;
};

}  // namespace

template <int D>
std::unique_ptr<CentralizedFilter> filter_kernels::make_lb_ekf_i(const VecX& mean,
                                                                 const std::vector<Mat<D>>& cov,
                                                                 const CentralizedFilterParams& params) {
  return std::make_unique<LbEkfI<D>>(mean, cov, params);
}
template std::unique_ptr<CentralizedFilter> filter_kernels::make_lb_ekf_i<2>(const VecX&,
                                                                             const std::vector<Mat2>&,
                                                                             const CentralizedFilterParams&);
template std::unique_ptr<CentralizedFilter> filter_kernels::make_lb_ekf_i<3>(const VecX&,
                                                                             const std::vector<Mat3>&,
                                                                             const CentralizedFilterParams&);

}  // namespace swarmloc::estimators::centralized
