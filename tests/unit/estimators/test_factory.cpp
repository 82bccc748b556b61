#include <gtest/gtest.h>

#include <stdexcept>

#include "swarmloc/estimators/estimator.hpp"

namespace swarmloc::estimators {
namespace {

TEST(Factory, KnowsIeifIekfAndThePoseFilters) {
  const auto& names = known_algorithms();
  for (const char* name : {"ieif", "iekf", "pose_ekf", "pose_ieif", "dead_reckoning"})
    EXPECT_NE(std::find(names.begin(), names.end(), name), names.end()) << name;
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
