// A MURP trial as the team sees it (world/murp_team.hpp): the truth each vehicle's estimate of a peer is
// scored against, what each vehicle's IMU and altimeter report, and the pooled scores.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "swarmloc/world/murp_team.hpp"

namespace {

using namespace swarmloc;
using namespace swarmloc::world;
namespace uwb = estimators::uwb;

constexpr double kPi = std::numbers::pi;

MurpPose pose(double x, double y, double z, double yaw, double roll = 0.0, double pitch = 0.0) {
  return {Vec3(x, y, z), roll, pitch, yaw};
}

MurpWindow window(double time, const MurpPose& base, const MurpPose& target) {
  MurpWindow w;
  w.time_s = time;
  w.base = base;
  w.target = target;
  w.ranges_m.setConstant(4.0);
  w.range_std_m.setConstant(0.05);
  return w;
}

/// Vehicles 1 and 2 only (a two-vehicle trial), two windows 1 s apart.
MurpTrial two_vehicles(const MurpPose& a0, const MurpPose& b0, const MurpPose& a1, const MurpPose& b1) {
  MurpTrial trial;
  trial.name = "99";
  trial.pairs.push_back({1, 2, {}, {window(0.0, a0, b0), window(1.0, a1, b1)}, 0});
  trial.pairs.push_back({2, 1, {}, {window(0.0, b0, a0), window(1.0, b1, a1)}, 0});
  return trial;
}

TEST(MurpTeam, TruthIsThePeerInTheBasesLevelFrameAndTheHeadingDifference) {
  const auto windows = murp_team_windows(two_vehicles(pose(1, 2, 1.75, kPi / 2), pose(1, 5, 0.5, kPi),
                                                      pose(1, 2, 1.75, kPi / 2), pose(1, 5, 0.5, kPi)));
  ASSERT_EQ(windows.size(), 2U);
  const auto& truth = windows[0].truth.at({1, 2});
  // B is 3 m north of A, which faces north: straight ahead, 1.25 m below.
  EXPECT_LT((truth.position_m - Vec3(3.0, 0.0, -1.25)).norm(), 1e-12);
  EXPECT_NEAR(truth.heading_rad, kPi / 2, 1e-12);
  const auto& back = windows[0].truth.at({2, 1});
  // A seen from B (facing west): 3 m to B's left... A is south of B, B faces west: A is on B's left.
  EXPECT_LT((back.position_m - Vec3(0.0, 3.0, 1.25)).norm(), 1e-12);
  EXPECT_NEAR(back.heading_rad, -kPi / 2, 1e-12);
}

TEST(MurpTeam, EachVehicleSensesItsTiltItsTurnSinceTheLastWindowAndItsAltitude) {
  const auto windows =
      murp_team_windows(two_vehicles(pose(0, 0, 1.75, 3.0, 0.02, -0.01), pose(4, 0, 0.5, 0.0),
                                     pose(0, 0, 1.76, -3.0, 0.02, -0.01), pose(4, 1, 0.5, 0.5)));
  const auto& first = windows[0].sensing.at(1);
  EXPECT_DOUBLE_EQ(first.turn_rad, 0.0);
  EXPECT_NEAR(*first.altitude_m, 1.75, 1e-12);
  // In the authors' R = Rx(roll)·Ry(pitch)·Rz(yaw) the tilt is about the world's axes; the IMU reports it
  // about the body's, turned by the yaw: (φ cos ψ + θ sin ψ, −φ sin ψ + θ cos ψ) to first order.
  EXPECT_NEAR(first.tilt.roll_rad, 0.02 * std::cos(3.0) - 0.01 * std::sin(3.0), 1e-4);
  EXPECT_NEAR(first.tilt.pitch_rad, -0.02 * std::sin(3.0) - 0.01 * std::cos(3.0), 1e-4);
  // From yaw 3.0 to −3.0 is a turn of 2π − 6 ≈ +0.283 rad, not −6.
  const auto& turned = windows[1].sensing.at(1);
  EXPECT_NEAR(turned.turn_rad, 2 * kPi - 6.0, 1e-3);
  EXPECT_NEAR(windows[1].sensing.at(2).turn_rad, 0.5, 1e-12);
  EXPECT_DOUBLE_EQ(windows[1].dt_s, 1.0);
  ASSERT_EQ(windows[1].ranges.at(1).size(), 1U);
  EXPECT_EQ(windows[1].ranges.at(1)[0].peer, 2);
}

TEST(MurpTeam, ScoresPoolEveryPairAndCountWhatIsMissingOrUnscorable) {
  const auto windows = murp_team_windows(
      two_vehicles(pose(0, 0, 0.5, 0.0), pose(3, 0, 0.5, 0.0), pose(0, 0, 0.5, 0.0), pose(0, 4, 0.5, 0.0)));
  std::vector<RelativeEstimateRow> rows;
  // 1 sees 2: 0.3 m and 0.1 rad off in window 0, exact in window 1; 2 sees 1 reports window 1 only.
  rows.push_back({0, 1, 2, {{Vec3(3.3, 0.0, 0.0), 0.1}, uwb::Mat4::Identity()}});
  rows.push_back({1, 1, 2, {{Vec3(0.0, 4.0, 0.0), 0.0}, uwb::Mat4::Identity()}});
  rows.push_back({1, 2, 1, {{Vec3(0.0, -4.0, 0.0), 0.0}, uwb::Mat4::Identity()}});
  rows.push_back({7, 2, 1, {{Vec3::Zero(), 0.0}, uwb::Mat4::Identity()}});  // no such window
  const auto score = score_murp(windows, rows);
  EXPECT_EQ(score.pooled.windows, 3);
  EXPECT_NEAR(score.pooled.position_mae_m(), 0.1, 1e-12);
  EXPECT_NEAR(score.pooled.position_rmse_m(), std::sqrt(0.09 / 3), 1e-12);
  EXPECT_NEAR(score.pooled.heading_mae_deg(), 0.1 * 180 / kPi / 3, 1e-9);
  EXPECT_NEAR(score.per_pair.at({1, 2}).range_normalized_mae(), 0.1 / 2, 1e-12);
  EXPECT_EQ(score.missing_estimates, 1);
  EXPECT_EQ(score.unscored_rows, 1);
}

}  // namespace
