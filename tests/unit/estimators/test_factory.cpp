#include <gtest/gtest.h>

#include <stdexcept>

#include "swarmloc/estimators/estimator.hpp"

namespace swarmloc::estimators {
namespace {

TEST(Factory, KnowsIeifAndIekf) {
  const auto& names = known_algorithms();
  EXPECT_NE(std::find(names.begin(), names.end(), "ieif"), names.end());
  EXPECT_NE(std::find(names.begin(), names.end(), "iekf"), names.end());
  for (const auto& name : names)
    EXPECT_EQ(make_estimator(name, AgentSetup{}, KalmanFamilyParams{})->name(), name);
}

TEST(Factory, UnknownNameThrowsListingTheKnownNames) {
  try {
    (void)make_estimator("kalmanish", AgentSetup{}, KalmanFamilyParams{});
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
