// The agents' inter-agent latency histogram: quantiles within its 2 % bucket width, constant memory.
#include <gtest/gtest.h>

#include <random>

#include "../../../common/dds/src/endpoints.hpp"

namespace swarmloc::dds {
namespace {

TEST(LatencyHistogram, QuantilesOfAKnownSpreadAreWithinTheBucketWidth) {
  LatencyHistogram histogram;
  // 1..1000 µs, one sample each: p50 ≈ 500 µs, p99 ≈ 990 µs.
  for (int us = 1000; us >= 1; --us) histogram.add(static_cast<std::int64_t>(us) * 1000);
  EXPECT_EQ(histogram.total(), 1000U);
  EXPECT_NEAR(histogram.quantile_us(0.50), 500.0, 0.02 * 500.0);
  EXPECT_NEAR(histogram.quantile_us(0.99), 990.0, 0.02 * 990.0);
  EXPECT_DOUBLE_EQ(histogram.quantile_us(0.0), 1.0);  // ≤ 1 µs
}

TEST(LatencyHistogram, NegativeAndHugeLatenciesAreCountedAtTheEnds) {
  LatencyHistogram histogram;
  histogram.add(-5'000'000);         // a writer on a host whose clock runs ahead
  histogram.add(3'600'000'000'000);  // an hour
  EXPECT_EQ(histogram.total(), 2U);
  EXPECT_DOUBLE_EQ(histogram.quantile_us(0.0), 1.0);
  EXPECT_GT(histogram.quantile_us(1.0), 2e6);
  histogram.clear();
  EXPECT_EQ(histogram.total(), 0U);
}

TEST(LatencyHistogram, MedianOfLogNormalSamplesMatchesTheSortedMedian) {
  std::mt19937_64 rng(7);
  std::lognormal_distribution<double> latency_us(std::log(400.0), 0.8);
  std::vector<double> samples;
  LatencyHistogram histogram;
  for (int i = 0; i < 20001; ++i) {
    samples.push_back(latency_us(rng));
    histogram.add(static_cast<std::int64_t>(samples.back() * 1000.0));
  }
  std::sort(samples.begin(), samples.end());
  EXPECT_NEAR(histogram.quantile_us(0.5), samples[10000], 0.02 * samples[10000]);
  EXPECT_NEAR(histogram.quantile_us(0.99), samples[19800], 0.02 * samples[19800]);
}

}  // namespace
}  // namespace swarmloc::dds
