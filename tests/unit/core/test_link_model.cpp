#include <gtest/gtest.h>

#include <cmath>
#include <vector>

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

// ---------------------------------------------------------------------------------------------------
// Gilbert–Elliott bursts

struct BurstStats {
  double loss = 0.0;         ///< dropped / samples
  double mean_burst = 0.0;   ///< mean run of consecutive drops (complete runs only)
  std::uint64_t bursts = 0;  ///< complete runs counted
};

BurstStats measure(const LinkLossModel& model, AgentId sender, AgentId receiver, std::uint64_t samples) {
  BurstStats stats;
  std::uint64_t dropped = 0;
  std::uint64_t run = 0;
  std::uint64_t run_total = 0;
  for (std::uint64_t seq = 0; seq < samples; ++seq) {
    if (model.drops(sender, receiver, TopicFamily::kState, seq)) {
      ++dropped;
      ++run;
    } else if (run > 0) {
      run_total += run;
      ++stats.bursts;
      run = 0;
    }
  }
  stats.loss = static_cast<double>(dropped) / static_cast<double>(samples);
  stats.mean_burst =
      stats.bursts > 0 ? static_cast<double>(run_total) / static_cast<double>(stats.bursts) : 0.0;
  return stats;
}

// Tolerances (4 sigma), from the chain's own statistics. The chain's second eigenvalue is
// lambda = 1 - rho with rho = 1/((1 - L) B), so the variance of the loss fraction over N samples is
// L (1 - L) / N * (1 + lambda) / (1 - lambda) (variance of the mean of an AR(1)-correlated 0/1 series).
// Burst lengths are i.i.d. geometric with mean B and variance B (B - 1), so the mean of K bursts has
// standard deviation sqrt(B (B - 1) / K).
TEST(LinkLossModel, BurstLossHasTheConfiguredMeanLossAndMeanBurstLength) {
  constexpr std::uint64_t kSamples = 200000;
  struct Case {
    double loss;
    double burst;
  };
  for (const Case c : {Case{0.3, 10.0}, Case{0.1, 3.0}, Case{0.5, 5.0}, Case{0.05, 20.0}, Case{0.6, 2.5}}) {
    const LinkLossModel model(2024, LinkLossParams{c.loss, c.burst});
    const auto stats = measure(model, 4, 9, kSamples);
    const double lambda = 1.0 - 1.0 / ((1.0 - c.loss) * c.burst);
    const double loss_sigma =
        std::sqrt(c.loss * (1.0 - c.loss) / static_cast<double>(kSamples) * (1.0 + lambda) / (1.0 - lambda));
    const double burst_sigma = std::sqrt(c.burst * (c.burst - 1.0) / static_cast<double>(stats.bursts));
    EXPECT_NEAR(stats.loss, c.loss, 4.0 * loss_sigma) << "L = " << c.loss << ", B = " << c.burst;
    EXPECT_NEAR(stats.mean_burst, c.burst, 4.0 * burst_sigma) << "L = " << c.loss << ", B = " << c.burst;
    // The expected number of complete bursts is N L / B; far fewer would mean the chain is stuck.
    EXPECT_GT(static_cast<double>(stats.bursts), 0.8 * kSamples * c.loss / c.burst);
  }
}

TEST(LinkLossModel, ShortestBurstLengthIsBernoulli) {
  // B = 1/(1 - L) redraws every sample: drops are independent, P(drop | previous drop) = L.
  constexpr std::uint64_t kSamples = 200000;
  const double loss = 0.3;
  const LinkLossModel model(77, LinkLossParams{loss, min_burst_mean_length(loss)});
  std::uint64_t after_drop = 0;
  std::uint64_t drop_after_drop = 0;
  bool previous = false;
  for (std::uint64_t seq = 0; seq < kSamples; ++seq) {
    const bool drop = model.drops(1, 2, TopicFamily::kState, seq);
    if (previous) {
      ++after_drop;
      drop_after_drop += drop ? 1 : 0;
    }
    previous = drop;
  }
  const double conditional = static_cast<double>(drop_after_drop) / static_cast<double>(after_drop);
  EXPECT_NEAR(conditional, loss, 4.0 * std::sqrt(loss * (1.0 - loss) / static_cast<double>(after_drop)));
  const auto stats = measure(model, 1, 2, kSamples);
  const double b = min_burst_mean_length(loss);
  EXPECT_NEAR(stats.mean_burst, b, 4.0 * std::sqrt(b * (b - 1.0) / static_cast<double>(stats.bursts)));
}

TEST(LinkLossModel, BurstDecisionsArePureFunctionsOfSeedLinkFamilyAndSeq) {
  const LinkLossModel a(5, LinkLossParams{0.3, 10.0});
  const LinkLossModel b(5, LinkLossParams{0.3, 10.0});
  constexpr std::uint64_t kSamples = 5000;
  std::vector<bool> forward(kSamples);
  for (std::uint64_t seq = 0; seq < kSamples; ++seq) forward[seq] = a.drops(3, 8, TopicFamily::kState, seq);
  // Another instance, asked in reverse order (as a receiver that saw the samples out of order would).
  for (std::uint64_t seq = kSamples; seq-- > 0;) {
    ASSERT_EQ(forward[seq], b.drops(3, 8, TopicFamily::kState, seq)) << "seq " << seq;
  }
  // Other links, families and seeds have their own chains.
  const LinkLossModel other_seed(6, LinkLossParams{0.3, 10.0});
  int direction_diff = 0;
  int family_diff = 0;
  int seed_diff = 0;
  for (std::uint64_t seq = 0; seq < kSamples; ++seq) {
    direction_diff += forward[seq] != a.drops(8, 3, TopicFamily::kState, seq) ? 1 : 0;
    family_diff += forward[seq] != a.drops(3, 8, TopicFamily::kInformation, seq) ? 1 : 0;
    seed_diff += forward[seq] != other_seed.drops(3, 8, TopicFamily::kState, seq) ? 1 : 0;
  }
  // Two independent chains with loss 0.3 disagree on 2 L (1 - L) = 42 % of samples on average.
  EXPECT_GT(direction_diff, kSamples / 4);
  EXPECT_GT(family_diff, kSamples / 4);
  EXPECT_GT(seed_diff, kSamples / 4);
}

TEST(LinkLossModel, BurstLossZeroAndOneAreExact) {
  const LinkLossModel never(7, LinkLossParams{0.0, 10.0});
  const LinkLossModel always(7, LinkLossParams{1.0, 10.0});
  for (std::uint64_t seq = 0; seq < 10000; ++seq) {
    EXPECT_FALSE(never.drops(0, 1, TopicFamily::kState, seq));
    EXPECT_TRUE(always.drops(0, 1, TopicFamily::kState, seq));
  }
}

}  // namespace
}  // namespace swarmloc::core
