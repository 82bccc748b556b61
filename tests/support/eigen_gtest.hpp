#pragma once
// EXPECT_MATRIX_NEAR(a, b, tol): element-wise comparison with a readable failure message.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <sstream>

namespace swarmloc::testing {

template <typename A, typename B>
::testing::AssertionResult matrices_near(const char* a_expr, const char* b_expr, const char*,
                                         const Eigen::MatrixBase<A>& a, const Eigen::MatrixBase<B>& b,
                                         double tolerance) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) {
    return ::testing::AssertionFailure() << a_expr << " is " << a.rows() << "x" << a.cols() << " but "
                                         << b_expr << " is " << b.rows() << "x" << b.cols();
  }
  const double max_diff = (a - b).cwiseAbs().maxCoeff();
  if (max_diff <= tolerance) return ::testing::AssertionSuccess();
  std::ostringstream os;
  os << a_expr << " and " << b_expr << " differ by " << max_diff << " > " << tolerance << "\n"
     << a_expr << " =\n"
     << a << "\n"
     << b_expr << " =\n"
     << b;
  return ::testing::AssertionFailure() << os.str();
}

}  // namespace swarmloc::testing

#define EXPECT_MATRIX_NEAR(a, b, tol) EXPECT_PRED_FORMAT3(::swarmloc::testing::matrices_near, a, b, tol)
#define ASSERT_MATRIX_NEAR(a, b, tol) ASSERT_PRED_FORMAT3(::swarmloc::testing::matrices_near, a, b, tol)
