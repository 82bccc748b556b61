#include "swarmloc/estimators/centralized/posterior_crb.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <stdexcept>

namespace swarmloc::estimators::centralized {
namespace {

MatX information_inverse(const MatX& a) {
  Eigen::LLT<MatX> llt(a);
  if (llt.info() != Eigen::Success)
    throw std::domain_error("PosteriorCrb: information is not positive definite");
  return llt.solve(MatX::Identity(a.rows(), a.cols()));
}

}  // namespace

PosteriorCrb::PosteriorCrb(const std::vector<Mat2>& initial_cov, double process_var)
    : initial_cov_(initial_cov), process_var_(process_var) {}

void PosteriorCrb::step(const CentralizedMeasurements& pattern, const VecX& true_positions) {
  const int n = static_cast<int>(true_positions.size());
  if (static_cast<std::size_t>(n) != 2 * initial_cov_.size()) {
    throw std::invalid_argument("PosteriorCrb: true_positions size does not match the number of agents");
  }
  MatX prior;
  if (steps_done_ == 0) {
    prior = MatX::Zero(n, n);  // Σ_0⁻¹ (block diagonal)
    for (std::size_t a = 0; a < initial_cov_.size(); ++a) {
      const auto i = 2 * static_cast<Eigen::Index>(a);
      prior.block<2, 2>(i, i) = initial_cov_[a].inverse();
    }
  } else {
    MatX predicted = bound_;
    predicted.diagonal().array() += process_var_;  // J_{k−1}⁻¹ + σ_p I
    prior = information_inverse(predicted);
  }
  // The residual vector is irrelevant here; S at the truth is the Fisher information of step k.
  information_ = prior + assemble_measurement_information(pattern, true_positions, {}).information;
  bound_ = information_inverse(information_);
  ++steps_done_;
}

}  // namespace swarmloc::estimators::centralized
