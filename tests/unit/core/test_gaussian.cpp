#include <gtest/gtest.h>

#include <limits>

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
