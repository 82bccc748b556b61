#include "swarmloc/core/gaussian.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace swarmloc::core {

bool all_finite(const Eigen::Ref<const MatX>& m) { return m.allFinite(); }

bool is_symmetric_psd(const Mat2& m, double tolerance) {
  if (!m.allFinite()) return false;
  const double scale = std::max(1.0, m.cwiseAbs().maxCoeff());
  if (std::abs(m(0, 1) - m(1, 0)) > tolerance * scale) return false;
  const Eigen::SelfAdjointEigenSolver<Mat2> eig(symmetrized(m), Eigen::EigenvaluesOnly);
  return eig.eigenvalues().minCoeff() >= -tolerance * scale;
}

bool is_symmetric_psd_dynamic(const MatX& m, double tolerance) {
  if (m.rows() != m.cols() || !m.allFinite()) return false;
  if (m.rows() == 0) return true;
  const double scale = std::max(1.0, m.cwiseAbs().maxCoeff());
  if ((m - m.transpose()).cwiseAbs().maxCoeff() > tolerance * scale) return false;
  const Eigen::SelfAdjointEigenSolver<MatX> eig(0.5 * (m + m.transpose()), Eigen::EigenvaluesOnly);
  return eig.info() == Eigen::Success && eig.eigenvalues().minCoeff() >= -tolerance * scale;
}

bool is_symmetric_pd(const Mat2& m, double tolerance) {
  if (!is_symmetric_psd(m, tolerance)) return false;
  return m(0, 0) > 0.0 && m.determinant() > 0.0;
}

}  // namespace swarmloc::core
