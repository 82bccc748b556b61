// The UWB relative pose filter and the team's loop closure (docs/algorithms.md §11): Jacobians against finite
// differences, exact recovery from noise-free multi-antenna ranges, and the fused covariance against the one
// propagated by hand.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "swarmloc/estimators/uwb/range_calibration.hpp"
#include "swarmloc/estimators/uwb/relative_pose.hpp"
#include "swarmloc/estimators/uwb/team_member.hpp"

namespace {

using namespace swarmloc;
using namespace swarmloc::estimators::uwb;

constexpr double kPi = std::numbers::pi;

RelativePoseParams ring_params() {
  RelativePoseParams params;
  params.my_lever_arms_m = ring_lever_arms(6, 0.32, kPi / 6.0);
  params.peer_lever_arms_m = ring_lever_arms(6, 0.32, kPi / 6.0);
  params.bias.my_antenna_offsets_m = (VecX(6) << -0.15, -0.2, -0.17, -0.19, -0.21, -0.2).finished();
  params.bias.peer_antenna_offsets_m = (VecX(6) << -0.08, -0.11, -0.05, -0.07, -0.08, -0.08).finished();
  params.bias.coefficients_m << 1.05, -0.6, 0.03, 0.01, 0.05;
  return params;
}

/// Noise-free ranges of `truth`, computed here from the antennas' positions (not through predict_ranges):
/// geometric range plus both antennas' offsets plus the coefficients times the geometry features.
RangeWindow exact_window(const RelativePose& truth, const RelativePoseParams& params, Tilt mine, Tilt peer) {
  RangeWindow window{MatX::Ones(6, 6), {}, mine, peer, truth.position_m.z()};
  const Mat3 my_attitude = level_rotation(mine);
  const Mat3 peer_attitude = yaw_rotation(truth.heading_rad) * level_rotation(peer);
  for (Eigen::Index i = 0; i < 6; ++i) {
    for (Eigen::Index j = 0; j < 6; ++j) {
      const Vec3& my_arm = params.my_lever_arms_m[static_cast<std::size_t>(i)];
      const Vec3& peer_arm = params.peer_lever_arms_m[static_cast<std::size_t>(j)];
      const Vec3 d = truth.position_m + peer_attitude * peer_arm - my_attitude * my_arm;
      const Vec3 u = d.normalized();
      const double facing_mine = (my_attitude * my_arm.normalized()).dot(u);
      const double facing_peer = -(peer_attitude * peer_arm.normalized()).dot(u);
      RangeBias::Features features;
      features << std::abs(u.z()), u.z() * u.z(), u.z(), facing_mine + facing_peer,
          facing_mine * facing_mine + facing_peer * facing_peer;
      window.ranges_m(i, j) = d.norm() + params.bias.my_antenna_offsets_m(i) +
                              params.bias.peer_antenna_offsets_m(j) +
                              params.bias.coefficients_m.dot(features);
    }
  }
  return window;
}

TEST(UwbRelativePose, RangeJacobianMatchesFiniteDifferencesWithBiasAndTilts) {
  const auto params = ring_params();
  const RelativePose pose{Vec3(3.1, -1.7, 1.2), 0.7};
  const RangeWindow window{MatX::Ones(6, 6), {}, {0.05, -0.03}, {-0.02, 0.04}, std::nullopt};
  const auto at = predict_ranges(pose, window, params);
  constexpr double kStep = 1e-6;
  for (int k = 0; k < 4; ++k) {
    Vec4 shifted = pose.vector();
    shifted(k) += kStep;
    const auto plus = predict_ranges(RelativePose::from(shifted), window, params);
    shifted(k) -= 2 * kStep;
    const auto minus = predict_ranges(RelativePose::from(shifted), window, params);
    const VecX numeric = (plus.predicted_m - minus.predicted_m) / (2 * kStep);
    EXPECT_LT((numeric - at.jacobian.col(k)).cwiseAbs().maxCoeff(), 1e-6) << "state component " << k;
  }
}

TEST(UwbRelativePose, NoiseFreeRangesAreSolvedExactlyFromAnyBearingAndHeading) {
  const auto params = ring_params();
  for (const RelativePose& truth :
       {RelativePose{Vec3(4.4, 0.6, -1.2), 1.17}, RelativePose{Vec3(-2.0, 3.5, 0.3), -2.4},
        RelativePose{Vec3(-1.5, -6.0, 1.25), 3.0}}) {
    RelativePoseFilter filter(params);
    ASSERT_TRUE(filter.update(exact_window(truth, params, {0.02, -0.01}, {-0.03, 0.02})));
    EXPECT_LT((filter.pose().position_m - truth.position_m).norm(), 1e-6) << truth.position_m.transpose();
    EXPECT_LT(std::abs(std::remainder(filter.pose().heading_rad - truth.heading_rad, 2 * kPi)), 1e-6);
    const Mat4& p = filter.covariance();
    EXPECT_LT((p - p.transpose()).norm(), 1e-12);
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<Mat4>(p).eigenvalues().minCoeff(), 0.0);
  }
}

TEST(UwbRelativePose, AWindowWithFewerThanFourRangesLeavesTheFilterAlone) {
  RelativePoseFilter filter(ring_params());
  RangeWindow window{MatX::Constant(6, 6, std::nan("")), {}, {}, {}, std::nullopt};
  window.ranges_m(0, 0) = window.ranges_m(1, 1) = window.ranges_m(2, 2) = 4.0;
  EXPECT_FALSE(filter.update(window));
  EXPECT_FALSE(filter.initialized());
}

TEST(UwbRelativePose, AFilterThatLostThePeerRelocksOnTheWindowsOwnSolution) {
  const auto params = ring_params();
  const RelativePose before{Vec3(4.0, 1.0, 0.5), 0.3};
  const RelativePose after{Vec3(-3.0, -2.5, 0.5), -2.0};
  RelativePoseFilter filter(params);
  for (int k = 0; k < 5; ++k) ASSERT_TRUE(filter.update(exact_window(before, params, {}, {})));
  // Far less time than the jump would take: the prior alone would hold the filter near `before`.
  filter.predict(0.01);
  ASSERT_TRUE(filter.update(exact_window(after, params, {}, {})));
  EXPECT_LT((filter.pose().position_m - after.position_m).norm(), 1e-6);
  EXPECT_EQ(filter.relocks(), 1);
}

TEST(UwbRelativePose, MyTurnRotatesThePeerTheOtherWayAndItsTurnAddsToTheHeading) {
  const auto params = ring_params();
  const RelativePose truth{Vec3(3.0, 0.0, 0.5), 0.2};
  RelativePoseFilter filter(params);
  ASSERT_TRUE(filter.update(exact_window(truth, params, {}, {})));
  filter.predict(1.0, kPi / 2.0, 0.1);
  EXPECT_LT((filter.pose().position_m - Vec3(0.0, -3.0, 0.5)).norm(), 1e-6);
  EXPECT_NEAR(filter.pose().heading_rad, 0.2 + 0.1 - kPi / 2.0, 1e-6);
}

TEST(UwbRelativePose, RangeSpreadWidensTheStdOfThatRangeOnly) {
  auto params = ring_params();
  params.spread_noise_gain = 2.0;
  RangeWindow window{MatX::Ones(6, 6) * 4.0, MatX::Zero(6, 6), {}, {}, std::nullopt};
  window.range_spread_m(2, 3) = 0.5;
  const auto prediction = predict_ranges({Vec3(4, 0, 0), 0.0}, window, params);
  EXPECT_NEAR(prediction.std_m(3 * 6 + 2), std::hypot(params.range_std_m, 2.0 * 0.25), 1e-12);
  EXPECT_DOUBLE_EQ(prediction.std_m(0), params.range_std_m);
}

TEST(UwbTeam, ComposeRelativeIsInvertedByComposingBack) {
  const RelativePose b{Vec3(2.0, 1.0, 0.3), 0.8};
  const RelativePose c{Vec3(-1.0, 4.0, -0.2), -2.1};
  const RelativePose b_sees_c = compose_relative(b, c);
  // C from B's pose and B's view of C: t_c = t_b + Rz(ψ_b) t_bc.
  EXPECT_LT((b.position_m + yaw_rotation(b.heading_rad) * b_sees_c.position_m - c.position_m).norm(), 1e-12);
  EXPECT_NEAR(std::remainder(b.heading_rad + b_sees_c.heading_rad - c.heading_rad, 2 * kPi), 0.0, 1e-12);
}

/// C's pose in my frame from B's pose and B's view of C.
Vec4 chain(const Vec4& b, const Vec4& b_sees_c) {
  const Vec3 t = b.head<3>() + yaw_rotation(b(3)) * b_sees_c.head<3>();
  return {t.x(), t.y(), t.z(), b(3) + b_sees_c(3)};
}

TEST(UwbTeam, LoopClosureMovesAnUnknownPeerToTheChainAndPropagatesItsCovariance) {
  const PoseEstimate b{{Vec3(2.0, 1.0, 0.3), 0.8}, Vec4(0.04, 0.09, 0.01, 0.02).asDiagonal()};
  const PoseEstimate relation{{Vec3(1.5, -2.5, 0.1), -0.6}, Vec4(0.05, 0.03, 0.02, 0.01).asDiagonal()};
  // What I know of C myself is nothing worth the name.
  const PoseEstimate c_alone{{Vec3(0.0, 0.0, 0.0), 0.0}, Mat4::Identity() * 1e8};
  const auto fused = fuse_team({{2, b}, {3, c_alone}}, {{2, 3, relation}});
  const Vec4 expected = chain(b.pose.vector(), relation.pose.vector());
  EXPECT_LT((fused.at(3).pose.vector() - expected).norm(), 1e-5);
  // Covariance: A P_b Aᵀ + B P_rel Bᵀ with the chain's Jacobians by central differences.
  Eigen::Matrix4d a;
  Eigen::Matrix4d j;
  for (int k = 0; k < 4; ++k) {
    Vec4 step = Vec4::Zero();
    step(k) = 1e-6;
    a.col(k) = (chain(b.pose.vector() + step, relation.pose.vector()) -
                chain(b.pose.vector() - step, relation.pose.vector())) /
               2e-6;
    j.col(k) = (chain(b.pose.vector(), relation.pose.vector() + step) -
                chain(b.pose.vector(), relation.pose.vector() - step)) /
               2e-6;
  }
  const Mat4 propagated = a * b.covariance * a.transpose() + j * relation.covariance * j.transpose();
  EXPECT_LT((fused.at(3).covariance - propagated).norm(), 1e-5 * propagated.norm());
  EXPECT_LT((fused.at(2).pose.vector() - b.pose.vector()).norm(), 1e-6);
}

TEST(UwbTeam, ARelationPublishedBothWaysCountsOnce) {
  const PoseEstimate b{{Vec3(2.0, 1.0, 0.3), 0.8}, Mat4::Identity() * 1e-10};
  const PoseEstimate c_alone{{Vec3(0.0, 0.0, 0.0), 0.0}, Mat4::Identity() * 1e8};
  const PoseEstimate b_sees_c{{Vec3(1.5, -2.5, 0.1), -0.6}, Mat4::Identity() * 0.01};
  const RelativePose c = RelativePose::from(chain(b.pose.vector(), b_sees_c.pose.vector()));
  const PoseEstimate c_sees_b{compose_relative(c, b.pose), Mat4::Identity() * 0.01};
  const auto one_way = fuse_team({{2, b}, {3, c_alone}}, {{2, 3, b_sees_c}});
  const auto both_ways = fuse_team({{2, b}, {3, c_alone}}, {{2, 3, b_sees_c}, {3, 2, c_sees_b}});
  // The same exchange published twice carries the information of one: the covariance does not shrink.
  EXPECT_NEAR(both_ways.at(3).covariance.trace(), one_way.at(3).covariance.trace(),
              1e-3 * one_way.at(3).covariance.trace());
}

TEST(UwbTeam, MembersSolveEachOtherAndIgnoreRelationsAboutThemselves) {
  RangeCalibration calibration;
  const auto arms = ring_lever_arms(6, 0.32, kPi / 6.0);
  for (const AgentId v : {1, 2, 3}) calibration.vehicles[v] = {arms, VecX::Zero(6)};
  const std::map<AgentId, RelativePose> world{
      {1, {Vec3(0, 0, 1.75), 0.1}}, {2, {Vec3(4, 1, 0.5), 1.2}}, {3, {Vec3(-2, 3, 0.5), -0.7}}};
  TeamMember member(1, {{2, range_model(calibration, 1, 2)}, {3, range_model(calibration, 1, 3)}});
  std::vector<PeerRanges> ranges;
  std::map<AgentId, VehicleSensing> peers;
  for (const AgentId peer : {2, 3}) {
    const RelativePose truth = compose_relative(world.at(1), world.at(peer));
    ranges.push_back({peer, exact_window(truth, range_model(calibration, 1, peer), {}, {}).ranges_m, {}});
    peers[peer] = {{}, 0.0, world.at(peer).position_m.z()};
  }
  const auto own = member.observe(0.0, {{}, 0.0, 1.75}, peers, ranges);
  ASSERT_EQ(own.size(), 2U);
  EXPECT_LT((own.at(2).pose.position_m - compose_relative(world.at(1), world.at(2)).position_m).norm(), 1e-6);
  // A relation that names me is not mine to fuse: a wildly wrong one changes nothing.
  const PoseEstimate wrong{{Vec3(50, 50, 50), 3.0}, Mat4::Identity() * 1e-6};
  const auto fused = member.fuse({{2, 1, wrong}, {1, 3, wrong}});
  EXPECT_LT((fused.at(2).pose.vector() - own.at(2).pose.vector()).norm(), 1e-9);
  EXPECT_LT((fused.at(3).pose.vector() - own.at(3).pose.vector()).norm(), 1e-9);
}

}  // namespace
