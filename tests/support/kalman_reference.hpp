#pragma once
// The textbook innovation-covariance form of the IEKF update (Gasparri & Pascucci eqs. (30)–(32)): factors
// the M×M S = H P Hᵀ + R. estimators::kalman_update computes the same result in O(M); the unit test checks
// the two agree and bench/estimators_step.cpp measures the difference.
#include "swarmloc/estimators/kalman/kernels.hpp"

namespace swarmloc::testing {

inline estimators::KalmanUpdate kalman_update_innovation_form(const Vec2& x, const Mat2& P,
                                                              const estimators::Linearization& rows) {
  const Eigen::Index ranges = rows.jacobian.rows();
  const Eigen::Index m = ranges + (rows.fix ? 2 : 0);
  Eigen::Matrix<double, Eigen::Dynamic, 2> H(m, 2);
  VecX nu(m);
  MatX R = MatX::Zero(m, m);
  H.topRows(ranges) = rows.jacobian;
  nu.head(ranges) = rows.innovation;
  R.topLeftCorner(ranges, ranges) = rows.variance.asDiagonal();
  if (rows.fix) {
    H.bottomRows(2) = Mat2::Identity();
    nu.tail(2) = rows.fix->position_m - x;
    R.bottomRightCorner(2, 2) = rows.fix->covariance;
  }
  const MatX S = H * P * H.transpose() + R;
  const Eigen::Matrix<double, 2, Eigen::Dynamic> K = Eigen::LDLT<MatX>(S).solve(H * P).transpose();
  const Mat2 I_KH = Mat2::Identity() - K * H;
  return estimators::KalmanUpdate{x + K * nu, I_KH * P * I_KH.transpose() + K * R * K.transpose()};
}

}  // namespace swarmloc::testing
