// 3-D positions on the wire: State.altitude / State.edge_peer_z and Estimate.altitude carry z exactly, are
// absent in planar worlds (whose samples grow by two empty sequences only), and a sample whose z part is
// broken is refused and counted like a broken planar part.
#include <gtest/gtest.h>

#include <limits>

#include "../../../common/dds/src/wire_codec.hpp"
#include "dds_test_support.hpp"
#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/runtime/agent_runtime.hpp"
#include "swarmloc/runtime/hostile.hpp"

namespace swarmloc::dds {
namespace {

constexpr double kAltNan = std::numeric_limits<double>::quiet_NaN();

/// make_state with two dml edge summaries whose doubles have no short decimal form.
estimators::StateMessage planar_state_with_edges() {
  auto message = test::make_state(0.0);
  message.anchor = false;
  message.edge_ranges = {{3, 1e4 / 3.0, 12.25, Vec2(0.1 + 0.2, -1.0 / 7.0)},
                         {5, 0.0, 0.5, Vec2(-4.0, 2.0 / 3.0)}};
  return message;
}

estimators::StateMessage spatial_state_with_edges() {
  auto message = planar_state_with_edges();
  message.altitude = Altitude{1.0 / 3.0, 0.7, Vec2(-0.1, 1.0 / 9.0)};
  message.edge_ranges[0].peer_z_m = 2.0 / 7.0;
  message.edge_ranges[1].peer_z_m = -1e-300;
  return message;
}

runtime::AgentRuntime altitude_runtime() {
  estimators::AgentSetup setup{0, false, Vec2(5.0, 5.0)};
  runtime::AgentRuntimeParams params;
  params.absurd_position_bound_m = 1e5;
  return runtime::AgentRuntime(config::make_estimator("ieif", setup, {}), setup, {1, 2, 3, 4, 5, 6, 7},
                               params);
}

std::uint32_t rejected(const runtime::AgentRuntime& agent, runtime::RejectReason reason) {
  return agent.rejected_by_reason()[static_cast<std::size_t>(reason)];
}

TEST(ConvertAltitude, PlanarStateHasNoAltitudeOnEitherSide) {
  const auto header = test::make_header(4, 17);
  const auto message = planar_state_with_edges();
  const auto back = codec::round_trip(header, message);
  ASSERT_TRUE(back.well_formed);
  test::expect_state_eq(back.message, message);
  EXPECT_FALSE(back.message.altitude.has_value());
  ASSERT_EQ(back.message.edge_ranges.size(), 2U);
  for (const auto& edge : back.message.edge_ranges) EXPECT_EQ(edge.peer_z_m, 0.0);
  EXPECT_EQ(back.message.edge_ranges[0].peer_mean_m, message.edge_ranges[0].peer_mean_m);
}

TEST(ConvertAltitude, PlanarStateGrowsByTwoEmptySequencesOnly) {
  // XCDR1 body without the encapsulation header: 88 bytes before State.altitude and .edge_peer_z (measured
  // on the previous IDL), + 40 per edge range; now 4 + 4 for the two empty sequences' lengths, and 4 + 4 for
  // the empty State.cavities and .cavity_offset_z after them (dml's cavities, test_convert_cavities.cpp).
  const auto header = test::make_header(4, 17);
  auto message = test::make_state(0.0);
  EXPECT_EQ(codec::state_xcdr1_size(header, message), 96U + 8U);
  message = planar_state_with_edges();
  EXPECT_EQ(codec::state_xcdr1_size(header, message), 88U + 2 * 40U + 8U + 8U);
  // 3-D: the altitude (length, padding to 8, four doubles) and one double per edge (length, padding).
  EXPECT_EQ(codec::state_xcdr1_size(header, spatial_state_with_edges()),
            88U + 2 * 40U + 4U + 4U + 32U + 8U + 16U + 8U);
}

TEST(ConvertAltitude, SpatialStateRoundTripsExactly) {
  const auto header = test::make_header(4, 17);
  const auto message = spatial_state_with_edges();
  const auto back = codec::round_trip(header, message);
  ASSERT_TRUE(back.well_formed);
  test::expect_state_eq(back.message, message);
  ASSERT_TRUE(back.message.altitude.has_value());
  EXPECT_EQ(back.message.altitude->z_m, message.altitude->z_m);
  EXPECT_EQ(back.message.altitude->variance_m2, message.altitude->variance_m2);
  EXPECT_EQ(back.message.altitude->cross_m2, message.altitude->cross_m2);
  ASSERT_EQ(back.message.edge_ranges.size(), 2U);
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(back.message.edge_ranges[k].peer, message.edge_ranges[k].peer);
    EXPECT_EQ(back.message.edge_ranges[k].peer_mean_m, message.edge_ranges[k].peer_mean_m);
    EXPECT_EQ(back.message.edge_ranges[k].peer_z_m, message.edge_ranges[k].peer_z_m) << k;
  }
  // A 3-D state that has no edge summaries in this sample.
  auto no_edges = message;
  no_edges.edge_ranges.clear();
  const auto alone = codec::round_trip(header, no_edges);
  ASSERT_TRUE(alone.well_formed);
  ASSERT_TRUE(alone.message.altitude.has_value());
  EXPECT_EQ(alone.message.altitude->z_m, 1.0 / 3.0);
}

TEST(ConvertAltitude, EdgePeerZOfAnotherLengthOrNonFiniteIsMalformedAndCounted) {
  const auto header = test::make_header(2, 0);
  const auto spatial = spatial_state_with_edges();  // two edge ranges
  const auto planar = planar_state_with_edges();
  ASSERT_TRUE(codec::round_trip_with_edge_peer_z(header, spatial, {0.5, -0.5}).well_formed);
  struct Case {
    const estimators::StateMessage* message;
    std::vector<double> edge_peer_z;
  };
  const Case cases[] = {{&spatial, {0.5}},
                        {&spatial, {0.5, 0.5, 0.5}},
                        {&spatial, {}},
                        {&planar, {0.5, 0.5}},
                        {&spatial, {0.5, kAltNan}},
                        {&spatial, {std::numeric_limits<double>::infinity(), 0.5}}};
  auto agent = altitude_runtime();
  std::uint32_t seq = 0;
  for (const auto& c : cases) {
    const auto back = codec::round_trip_with_edge_peer_z(header, *c.message, c.edge_peer_z);
    EXPECT_FALSE(back.well_formed) << c.edge_peer_z.size() << " peer z for " << c.message->edge_ranges.size();
    EXPECT_FALSE(agent.on_state(test::make_header(2, seq++), back.message, back.well_formed));
  }
  EXPECT_EQ(rejected(agent, runtime::RejectReason::kMalformed), std::size(cases));
}

TEST(ConvertAltitude, BrokenAltitudeIsRejectedWithThePlanarReasons) {
  using runtime::RejectReason;
  const auto good = spatial_state_with_edges();
  struct Case {
    RejectReason reason;
    void (*spoil)(estimators::StateMessage&);
  };
  const Case cases[] = {
      {RejectReason::kNonFinite, [](estimators::StateMessage& m) { m.altitude->z_m = kAltNan; }},
      {RejectReason::kNonFinite, [](estimators::StateMessage& m) { m.altitude->variance_m2 = kAltNan; }},
      {RejectReason::kNonFinite, [](estimators::StateMessage& m) { m.altitude->cross_m2.y() = -kAltNan; }},
      // Below the PSD check's tolerance: only var(z) >= 0 refuses it.
      {RejectReason::kNotSymmetricPsd,
       [](estimators::StateMessage& m) {
         m.altitude->variance_m2 = -1e-12;
         m.altitude->cross_m2.setZero();
       }},
      // Each 2x2 block PSD, the 3x3 not: (x, z) correlation 0.9 / sqrt(0.5 * 0.7) > 1.
      {RejectReason::kNotSymmetricPsd, [](estimators::StateMessage& m) { m.altitude->cross_m2.x() = 0.9; }},
      // |(x, y)| is 12.6 m, |(x, y, z)| beyond the 1e5 m bound.
      {RejectReason::kAbsurdMagnitude, [](estimators::StateMessage& m) { m.altitude->z_m = 1.5e5; }},
      {RejectReason::kAbsurdMagnitude, [](estimators::StateMessage& m) { m.edge_ranges[1].peer_z_m = -2e5; }},
  };
  auto agent = altitude_runtime();
  ASSERT_TRUE(
      agent.on_state(test::make_header(1, 0), codec::round_trip(test::make_header(1, 0), good).message));
  std::array<std::uint32_t, runtime::kRejectReasonCount> expected{};
  AgentId sender = 2;
  for (const auto& c : cases) {
    auto hostile = good;
    c.spoil(hostile);
    const auto header = test::make_header(sender, 0);
    const auto back = codec::round_trip(header, hostile);
    ASSERT_TRUE(back.well_formed) << "the runtime judges the values, not the decoder";
    EXPECT_FALSE(agent.on_state(header, back.message, back.well_formed)) << "sender " << sender;
    ++expected[static_cast<std::size_t>(c.reason)];
    EXPECT_EQ(agent.rejected_by_reason(), expected) << "sender " << sender;
    sender = sender == 7 ? 2 : sender + 1;
  }
}

TEST(ConvertAltitude, HostileSpatialStatesBreakTheirZPartAndAreCaughtByIt) {
  // --hostile in a 3-D world: NaN z, a non-PSD (x, y, z) covariance, an absurd z, in turn; the planar part
  // stays plausible, so only the altitude checks can refuse them.
  using runtime::RejectReason;
  auto agent = altitude_runtime();
  const RejectReason expected[] = {RejectReason::kNonFinite, RejectReason::kNotSymmetricPsd,
                                   RejectReason::kAbsurdMagnitude};
  for (std::int64_t step = 0; step < 3; ++step) {
    estimators::Outbox outbox;
    outbox.state = spatial_state_with_edges();
    runtime::make_hostile(outbox, step);
    const auto header = test::make_header(1, static_cast<std::uint32_t>(step));
    auto planar_part = *outbox.state;
    planar_part.altitude.reset();
    EXPECT_TRUE(altitude_runtime().on_state(header, planar_part)) << step;
    const auto back = codec::round_trip(header, *outbox.state);
    ASSERT_TRUE(back.well_formed);
    EXPECT_FALSE(agent.on_state(header, back.message));
    EXPECT_EQ(rejected(agent, expected[step]), 1U) << step;
  }
}

// An anchor's fix in a 3-D world carries its z (the fusion centre's beacon in space); a planar fix has none.
TEST(ConvertAltitude, AFixCarriesItsZExactlyOrNone) {
  const auto header = test::make_header(kOrchestratorId, 8);
  auto batch = test::make_batch(header.step, header.world_stamp_ns);
  ASSERT_TRUE(batch.fix.has_value());
  const auto planar = codec::round_trip(5, header, batch);
  ASSERT_TRUE(planar.well_formed);
  ASSERT_TRUE(planar.batch.fix.has_value());
  EXPECT_FALSE(planar.batch.fix->z_m.has_value());
  batch.fix->z_m = 1.0 / 7.0;
  const auto spatial = codec::round_trip(5, header, batch);
  ASSERT_TRUE(spatial.well_formed);
  test::expect_batch_eq(spatial.batch, batch);
  ASSERT_TRUE(spatial.batch.fix->z_m.has_value());
  EXPECT_EQ(*spatial.batch.fix->z_m, 1.0 / 7.0);
}

TEST(ConvertAltitude, EstimateCarriesTheAltitudeExactlyOrNone) {
  auto report = test::make_estimate(11, 2);
  const auto planar = codec::round_trip(report);
  ASSERT_TRUE(planar.well_formed);
  EXPECT_FALSE(planar.report.estimate.altitude.has_value());
  report.estimate.altitude = Altitude{-2.0 / 3.0, 0.4, Vec2(1.0 / 30.0, -0.02)};
  const auto spatial = codec::round_trip(report);
  ASSERT_TRUE(spatial.well_formed);
  test::expect_estimate_eq(spatial.report, report);
  ASSERT_TRUE(spatial.report.estimate.altitude.has_value());
  EXPECT_EQ(spatial.report.estimate.altitude->z_m, -2.0 / 3.0);
  EXPECT_EQ(spatial.report.estimate.altitude->variance_m2, 0.4);
  EXPECT_EQ(spatial.report.estimate.altitude->cross_m2, Vec2(1.0 / 30.0, -0.02));
}

TEST(ConvertAltitude, EstimateWithBrokenAltitudeIsRefusedAtIntake) {
  auto report = test::make_estimate(11, 2);  // covariance xx 0.2, xy 0.01, yy 0.3
  const Altitude good{-2.0 / 3.0, 0.4, Vec2(1.0 / 30.0, -0.02)};
  const Altitude broken[] = {
      {kAltNan, 0.4, Vec2(0.0, 0.0)},
      {0.0, std::numeric_limits<double>::infinity(), Vec2(0.0, 0.0)},
      {0.0, 0.4, Vec2(kAltNan, 0.0)},
      {0.0, -1e-12, Vec2(0.0, 0.0)},  // below the PSD tolerance: var(z) >= 0 refuses it
      {0.0, 0.4, Vec2(0.0, 0.35)},    // (y, z) correlation 0.35 / sqrt(0.3 * 0.4) > 1
  };
  report.estimate.altitude = good;
  ASSERT_TRUE(codec::round_trip(report).well_formed);
  for (const auto& altitude : broken) {
    report.estimate.altitude = altitude;
    EXPECT_FALSE(codec::round_trip(report).well_formed)
        << altitude.z_m << " " << altitude.variance_m2 << " " << altitude.cross_m2.transpose();
  }
}

}  // namespace
}  // namespace swarmloc::dds
