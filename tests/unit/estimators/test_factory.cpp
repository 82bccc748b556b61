#include <gtest/gtest.h>

#include <stdexcept>

#include "named_estimators.hpp"
#include "swarmloc/estimators/estimator.hpp"

namespace swarmloc::estimators {
namespace {

TEST(Factory, KnowsIeifIekfAndThePoseFilters) {
  const auto names = testing::kalman_block_algorithms();
  for (const char* name : {"ieif", "iekf", "pose_ekf", "pose_ieif", "dead_reckoning"})
    EXPECT_NE(std::find(names.begin(), names.end(), name), names.end()) << name;
  for (const auto& name : names)
    EXPECT_EQ(testing::make_named_estimator(name, AgentSetup{}, KalmanFilterParams{})->name(), name);
}

TEST(Factory, UnknownNameThrowsListingTheKnownNames) {
  try {
    (void)testing::make_named_estimator("kalmanish", AgentSetup{}, KalmanFilterParams{});
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("kalmanish"), std::string::npos);
    EXPECT_NE(message.find("ieif"), std::string::npos);
    EXPECT_NE(message.find("iekf"), std::string::npos);
  }
}

}  // namespace
}  // namespace swarmloc::estimators
