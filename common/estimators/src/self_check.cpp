#include "swarmloc/estimators/self_check.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace swarmloc::estimators {

double standard_normal_upper_quantile(double upper_tail) {
  if (!(upper_tail > 0.0 && upper_tail < 1.0))
    throw std::invalid_argument("standard_normal_upper_quantile: the tail must be in (0, 1)");
  if (upper_tail > 0.5) return -standard_normal_upper_quantile(1.0 - upper_tail);
  // Abramowitz & Stegun 26.2.23: a rational approximation in t = sqrt(−2 ln p).
  const double t = std::sqrt(-2.0 * std::log(upper_tail));
  const double numerator = 2.515517 + t * (0.802853 + t * 0.010328);
  const double denominator = 1.0 + t * (1.432788 + t * (0.189269 + t * 0.001308));
  return t - numerator / denominator;
}

double chi_square_upper_quantile(double dof, double upper_tail) {
  if (!(dof > 0.0) || !std::isfinite(dof))
    throw std::invalid_argument("chi_square_upper_quantile: dof must be finite and > 0");
  const double z = standard_normal_upper_quantile(upper_tail);
  const double spread = 2.0 / (9.0 * dof);
  const double cube_root = 1.0 - spread + z * std::sqrt(spread);
  return cube_root > 0.0 ? dof * cube_root * cube_root * cube_root : 0.0;
}

RangeResidualCheck::RangeResidualCheck(const SelfCheckParams& params) : params_(params) {
  if (params.window_steps < 1) throw std::invalid_argument("RangeResidualCheck: window_steps must be >= 1");
  (void)standard_normal_upper_quantile(params.false_alarm);  // validates the size
}

void RangeResidualCheck::add(double residual_m, double variance_m2) {
  if (!std::isfinite(residual_m) || !std::isfinite(variance_m2) || !(variance_m2 > 0.0)) return;
  open_.sum += residual_m * residual_m / variance_m2;
  ++open_.count;
}

void RangeResidualCheck::end_step() {
  // A step without ranges (prediction only: no batch, or the DDS settle phase after the last world step)
  // tells nothing: it must not push the evidence out of the window and clear the verdict.
  if (open_.count == 0) return;
  window_.push_back(open_);
  open_ = {};
  while (window_.size() > static_cast<std::size_t>(params_.window_steps)) window_.pop_front();
  // Summed afresh (a short window): a running sum would drift below zero after large terms leave it.
  window_sum_ = 0.0;
  window_count_ = 0;
  for (const StepTotals& step : window_) {
    window_sum_ += step.sum;
    window_count_ += step.count;
  }
}

double RangeResidualCheck::threshold() const {
  if (window_count_ == 0) return std::numeric_limits<double>::infinity();
  return chi_square_upper_quantile(static_cast<double>(window_count_), params_.false_alarm);
}

}  // namespace swarmloc::estimators
