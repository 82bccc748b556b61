#include <gtest/gtest.h>

#include <cmath>

#include "swarmloc/core/link_model.hpp"

namespace swarmloc::core {
namespace {

TEST(LinkLossModel, DropFrequencyMatchesProbabilityWithinFourSigma) {
  constexpr int kSamples = 100000;
  for (const double p : {0.05, 0.3, 0.7}) {
    const LinkLossModel model(1234, LinkLossParams{p});
    int dropped = 0;
    for (std::uint64_t seq = 0; seq < kSamples; ++seq)
      dropped += model.drops(3, 8, TopicFamily::kState, seq) ? 1 : 0;
    const double sigma = std::sqrt(p * (1.0 - p) / kSamples);
    EXPECT_NEAR(static_cast<double>(dropped) / kSamples, p, 4.0 * sigma) << "p = " << p;
  }
}

TEST(LinkLossModel, SameInputsGiveTheSameDecision) {
  const LinkLossModel a(99, LinkLossParams{0.5});
  const LinkLossModel b(99, LinkLossParams{0.5});
  for (std::uint64_t seq = 0; seq < 1000; ++seq) {
    EXPECT_EQ(a.drops(1, 2, TopicFamily::kState, seq), b.drops(1, 2, TopicFamily::kState, seq));
    EXPECT_EQ(a.drops(1, 2, TopicFamily::kState, seq), a.drops(1, 2, TopicFamily::kState, seq));
  }
}

TEST(LinkLossModel, DecisionsDependOnSeedLinkAndFamily) {
  const LinkLossModel a(99, LinkLossParams{0.5});
  const LinkLossModel b(100, LinkLossParams{0.5});
  int seed_diff = 0;
  int direction_diff = 0;
  int family_diff = 0;
  for (std::uint64_t seq = 0; seq < 1000; ++seq) {
    const bool base = a.drops(1, 2, TopicFamily::kState, seq);
    seed_diff += base != b.drops(1, 2, TopicFamily::kState, seq) ? 1 : 0;
    direction_diff += base != a.drops(2, 1, TopicFamily::kState, seq) ? 1 : 0;
    family_diff += base != a.drops(1, 2, TopicFamily::kMeasurement, seq) ? 1 : 0;
  }
  // Independent fair coins differ about half the time.
  EXPECT_GT(seed_diff, 400);
  EXPECT_GT(direction_diff, 400);
  EXPECT_GT(family_diff, 400);
}

TEST(LinkLossModel, LossZeroNeverDropsAndLossOneAlwaysDrops) {
  const LinkLossModel never(7, LinkLossParams{0.0});
  const LinkLossModel always(7, LinkLossParams{1.0});
  for (std::uint64_t seq = 0; seq < 10000; ++seq) {
    EXPECT_FALSE(never.drops(0, 1, TopicFamily::kState, seq));
    EXPECT_TRUE(always.drops(0, 1, TopicFamily::kState, seq));
  }
}

}  // namespace
}  // namespace swarmloc::core
