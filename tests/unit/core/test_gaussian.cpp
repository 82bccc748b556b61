#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>
#include <random>

#include "swarmloc/core/gaussian.hpp"

namespace swarmloc::core {
namespace {

TEST(Gaussian, SymmetricPsdAcceptsPdAndSingularPsd) {
  EXPECT_TRUE(is_symmetric_psd(Mat2{{2.0, 0.5}, {0.5, 1.0}}));
  EXPECT_TRUE(is_symmetric_psd(Mat2{{1.0, 1.0}, {1.0, 1.0}}));  // rank 1
  EXPECT_TRUE(is_symmetric_psd(Mat2::Zero()));
}

TEST(Gaussian, SymmetricPsdRejectsNanAsymmetryAndNegativeEigenvalues) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(is_symmetric_psd(Mat2{{nan, 0.0}, {0.0, 1.0}}));
  EXPECT_FALSE(is_symmetric_psd(Mat2{{inf, 0.0}, {0.0, 1.0}}));
  EXPECT_FALSE(is_symmetric_psd(Mat2{{1.0, 0.5}, {0.2, 1.0}}));
  EXPECT_FALSE(is_symmetric_psd(Mat2{{1.0, 2.0}, {2.0, 1.0}}));  // eigenvalues 3, −1
  EXPECT_FALSE(is_symmetric_psd(Mat2{{-1e-3, 0.0}, {0.0, 1.0}}));
}

// The closed-form 2×2 check agrees with Eigen's symmetric eigensolver on random symmetric matrices of
// every scale (skipping the ones within 1e-6 relative of the boundary, where rounding may differ).
TEST(Gaussian, SymmetricPsdClosedFormAgreesWithTheEigensolver) {
  constexpr double kTolerance = 1e-9;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int compared = 0;
  int accepted = 0;
  for (int k = 0; k < 20000; ++k) {
    const double scale = std::pow(10.0, 12.0 * u(rng));
    const double off = scale * u(rng);
    const Mat2 m{{scale * u(rng), off}, {off, scale * u(rng)}};
    const Eigen::SelfAdjointEigenSolver<Mat2> eig(m, Eigen::EigenvaluesOnly);
    // The documented rule: λ_min ≥ −tolerance · max(1, max |m_ij|).
    const double margin = eig.eigenvalues().minCoeff() + kTolerance * std::max(1.0, m.cwiseAbs().maxCoeff());
    if (std::abs(margin) < 1e-6 * m.cwiseAbs().maxCoeff()) continue;
    ++compared;
    accepted += margin > 0.0 ? 1 : 0;
    EXPECT_EQ(is_symmetric_psd(m, kTolerance), margin > 0.0) << m;
  }
  EXPECT_GT(compared, 19000);
  EXPECT_GT(accepted, 2000) << "both outcomes must be exercised";
}

TEST(Gaussian, SymmetricPdRejectsSingularMatrices) {
  EXPECT_TRUE(is_symmetric_pd(Mat2{{2.0, 0.5}, {0.5, 1.0}}));
  EXPECT_FALSE(is_symmetric_pd(Mat2{{1.0, 1.0}, {1.0, 1.0}}));
  EXPECT_FALSE(is_symmetric_pd(Mat2::Zero()));
  EXPECT_FALSE(is_symmetric_pd(Mat2{{-1.0, 0.0}, {0.0, -1.0}}));
}

TEST(Gaussian, AllFiniteAndSymmetrized) {
  EXPECT_TRUE(all_finite(MatX::Ones(3, 4)));
  MatX m = MatX::Ones(3, 4);
  m(2, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(all_finite(m));
  const Mat2 s = symmetrized(Mat2{{1.0, 2.0}, {4.0, 3.0}});
  EXPECT_EQ(s(0, 1), 3.0);
  EXPECT_EQ(s(1, 0), 3.0);
}

}  // namespace
}  // namespace swarmloc::core
