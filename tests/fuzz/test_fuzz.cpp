// The fuzz targets (fuzz_targets.hpp) as unit tests: 20 000 inputs per target, fixed seed. They also run
// in the AddressSanitizer + UndefinedBehaviorSanitizer stage of scripts/test. For 10^6 inputs per target
// run `build/tests/swarmloc_fuzz --inputs 1000000 --seed S`.
#include <gtest/gtest.h>

#include "fuzz_targets.hpp"

namespace swarmloc::fuzz {
namespace {

constexpr std::uint64_t kInputs = 20000;
constexpr std::uint64_t kSeed = 20240601;

class FuzzTarget : public ::testing::TestWithParam<std::string> {};

TEST_P(FuzzTarget, NoContractViolationIn20000MutatedInputs) {
  const FuzzResult result = run_target(GetParam(), kSeed, kInputs);
  EXPECT_EQ(result.inputs, kInputs);
  EXPECT_EQ(result.accepted + result.rejected, kInputs);
  EXPECT_EQ(result.violations, 0U) << [&] {
    std::string text;
    for (const auto& failure : result.failures) text += failure + "\n";
    return text;
  }();
  // Both outcomes must be reached, or the mutator is not exercising the contract.
  EXPECT_GT(result.accepted, kInputs / 100);
  EXPECT_GT(result.rejected, kInputs / 100);
}

TEST(Fuzz, InputsAreReproducibleFromSeedAndIndex) {
  // Input i depends only on (seed, target, i): running 100 inputs from index 300 counts the same as the
  // tail of a run over 400 inputs minus a run over 300.
  for (const auto& target : {std::string("scenario"), std::string("information")}) {
    const auto all = run_target(target, 7, 400);
    const auto head = run_target(target, 7, 300);
    const auto tail = run_target(target, 7, 100, 300);
    EXPECT_EQ(head.accepted + tail.accepted, all.accepted) << target;
  }
}

INSTANTIATE_TEST_SUITE_P(Targets, FuzzTarget, ::testing::ValuesIn(target_names()),
                         [](const auto& test_info) { return test_info.param; });

}  // namespace
}  // namespace swarmloc::fuzz
