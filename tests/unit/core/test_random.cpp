#include <gtest/gtest.h>

#include <cmath>

#include "swarmloc/core/random.hpp"

namespace swarmloc::core {
namespace {

TEST(Random, HashIsDeterministicAndKeySensitive) {
  EXPECT_EQ(hash_keys(1, 2, 3), hash_keys(1, 2, 3));
  EXPECT_NE(hash_keys(1, 2, 3), hash_keys(1, 3, 2));
  EXPECT_NE(hash_keys(1, 2, 3), hash_keys(2, 2, 3));
  static_assert(hash_keys(5, 6) == hash_keys(5, 6));  // usable at compile time
}

TEST(Random, UnitUniformIsInHalfOpenUnitInterval) {
  EXPECT_EQ(unit_uniform(0), 0.0);
  EXPECT_LT(unit_uniform(~0ULL), 1.0);
  double sum = 0.0;
  constexpr int kSamples = 100000;
  for (int i = 0; i < kSamples; ++i) sum += unit_uniform(hash_keys(3, i));
  EXPECT_NEAR(sum / kSamples, 0.5, 4.0 * std::sqrt(1.0 / 12.0 / kSamples));
}

TEST(Random, EnginesDependOnStreamAndKeys) {
  auto a = make_engine(7, Stream::kPlacement, 1);
  auto b = make_engine(7, Stream::kPlacement, 1);
  auto c = make_engine(7, Stream::kMeasurementNoise, 1);
  auto d = make_engine(7, Stream::kPlacement, 2);
  const auto first = a();
  EXPECT_EQ(first, b());
  EXPECT_NE(first, c());
  EXPECT_NE(first, d());
}

}  // namespace
}  // namespace swarmloc::core
