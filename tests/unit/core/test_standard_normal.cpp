// core::standard_normal: the counter-based Gaussian used by the measurement generator.
#include <gtest/gtest.h>

#include <cmath>

#include "swarmloc/core/random.hpp"

namespace swarmloc::core {
namespace {

TEST(StandardNormal, HasZeroMeanUnitVarianceAndNormalTails) {
  constexpr int kDraws = 200000;
  double sum = 0.0, sum_sq = 0.0;
  int within_one_sigma = 0, beyond_three_sigma = 0;
  for (int k = 0; k < kDraws; ++k) {
    const double x = standard_normal(hash_keys(7, k));
    ASSERT_TRUE(std::isfinite(x));
    sum += x;
    sum_sq += x * x;
    within_one_sigma += std::abs(x) <= 1.0 ? 1 : 0;
    beyond_three_sigma += std::abs(x) > 3.0 ? 1 : 0;
  }
  const double mean = sum / kDraws;
  const double variance = sum_sq / kDraws - mean * mean;
  EXPECT_NEAR(mean, 0.0, 4.0 / std::sqrt(kDraws));
  EXPECT_NEAR(variance, 1.0, 4.0 * std::sqrt(2.0 / kDraws));
  const double p1 = 0.682689492;  // P(|X| <= 1)
  EXPECT_NEAR(static_cast<double>(within_one_sigma) / kDraws, p1, 4.0 * std::sqrt(p1 * (1 - p1) / kDraws));
  const double p3 = 0.002699796;  // P(|X| > 3)
  EXPECT_NEAR(static_cast<double>(beyond_three_sigma) / kDraws, p3, 4.0 * std::sqrt(p3 * (1 - p3) / kDraws));
}

TEST(StandardNormal, IsAPureFunctionOfTheKey) {
  EXPECT_EQ(standard_normal(hash_keys(1, 2, 3)), standard_normal(hash_keys(1, 2, 3)));
  EXPECT_NE(standard_normal(hash_keys(1, 2, 3)), standard_normal(hash_keys(1, 2, 4)));
}

}  // namespace
}  // namespace swarmloc::core
