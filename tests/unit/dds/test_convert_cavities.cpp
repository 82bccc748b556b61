// dml's cavities on the wire: State.cavities and, in 3-D, State.cavity_offset_z carry them bit for bit; a
// sample whose cavities are non-finite, have a negative variance, are more than 64, or whose offset z's do
// not match them is malformed and counted so.
#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <limits>
#include <numeric>

#include "../../../common/dds/src/wire_codec.hpp"
#include "dds_test_support.hpp"
#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/runtime/agent_runtime.hpp"

namespace swarmloc::dds {
namespace {

constexpr double kCavityNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kCavityInf = std::numeric_limits<double>::infinity();

std::uint64_t bits_of(double value) { return std::bit_cast<std::uint64_t>(value); }

/// Every field of each cavity equal bit for bit (-0 and denormals included).
void expect_cavities_bit_exact(const std::vector<estimators::EdgeCavity>& got,
                               const std::vector<estimators::EdgeCavity>& sent) {
  ASSERT_EQ(got.size(), sent.size());
  for (std::size_t k = 0; k < got.size(); ++k) {
    EXPECT_EQ(got[k].peer, sent[k].peer) << k;
    EXPECT_EQ(bits_of(got[k].offset_m.x()), bits_of(sent[k].offset_m.x())) << k;
    EXPECT_EQ(bits_of(got[k].offset_m.y()), bits_of(sent[k].offset_m.y())) << k;
    EXPECT_EQ(bits_of(got[k].offset_z_m), bits_of(sent[k].offset_z_m)) << k;
    EXPECT_EQ(bits_of(got[k].variance_m2), bits_of(sent[k].variance_m2)) << k;
  }
}

/// A planar dml state with three cavities whose doubles have no short decimal form, a -0, a denormal and a
/// zero variance.
estimators::StateMessage planar_state_with_cavities() {
  auto message = test::make_state(0.0);
  message.anchor = false;
  message.cavities = {{3, Vec2(0.1 + 0.2, -1.0 / 7.0), 0.0, 2.0 / 3.0},
                      {-1, Vec2(-0.0, std::numeric_limits<double>::denorm_min()), 0.0, 0.0},
                      {41, Vec2(-2.5e5, 1e-300), 0.0, 1e13 / 3.0}};
  return message;
}

estimators::StateMessage spatial_state_with_cavities() {
  auto message = planar_state_with_cavities();
  message.altitude = Altitude{1.0 / 3.0, 0.7, Vec2(-0.1, 1.0 / 9.0)};
  message.cavities[0].offset_z_m = 2.0 / 7.0;
  message.cavities[1].offset_z_m = -0.0;
  message.cavities[2].offset_z_m = -1e-310;
  return message;
}

runtime::AgentRuntime cavity_runtime() {
  estimators::AgentSetup setup{0, false, Vec2(5.0, 5.0)};
  return runtime::AgentRuntime(config::make_estimator("ieif", setup, {}), setup, {1, 2, 3},
                               runtime::AgentRuntimeParams{});
}

TEST(ConvertCavities, PlanarCavitiesRoundTripBitForBitWithoutOffsetZ) {
  const auto header = test::make_header(4, 17);
  const auto message = planar_state_with_cavities();
  const auto back = codec::round_trip(header, message);
  ASSERT_TRUE(back.well_formed);
  test::expect_state_eq(back.message, message);
  EXPECT_FALSE(back.message.altitude.has_value());
  expect_cavities_bit_exact(back.message.cavities, message.cavities);
  // A planar writer sends no offset z: a z set by mistake reads back as +0, not as what was set.
  auto stray_z = message;
  stray_z.cavities[0].offset_z_m = 5.0;
  const auto planar = codec::round_trip(header, stray_z);
  ASSERT_TRUE(planar.well_formed);
  EXPECT_EQ(bits_of(planar.message.cavities[0].offset_z_m), bits_of(0.0));
  // XCDR1: the State without cavities is 104 bytes; a cavity is 32 (peer, padding to 8, offset, variance),
  // the first 28 (its peer fills the 4 bytes after the sequence's length).
  EXPECT_EQ(codec::state_xcdr1_size(header, test::make_state(0.0)), 104U);
  EXPECT_EQ(codec::state_xcdr1_size(header, message), 104U + 28U + 2 * 32U);
}

TEST(ConvertCavities, SpatialCavitiesRoundTripBitForBitWithTheirOffsetZ) {
  const auto header = test::make_header(4, 17);
  const auto message = spatial_state_with_cavities();
  const auto back = codec::round_trip(header, message);
  ASSERT_TRUE(back.well_formed);
  ASSERT_TRUE(back.message.altitude.has_value());
  EXPECT_EQ(back.message.altitude->z_m, 1.0 / 3.0);
  expect_cavities_bit_exact(back.message.cavities, message.cavities);
  EXPECT_EQ(bits_of(back.message.cavities[1].offset_z_m), bits_of(-0.0));
  EXPECT_EQ(bits_of(back.message.cavities[2].offset_z_m), bits_of(-1e-310));
}

TEST(ConvertCavities, SixtyFourCavitiesGoOutAndSixtyFiveAreRefusedOnWrite) {
  const auto header = test::make_header(4, 17);
  auto message = spatial_state_with_cavities();
  message.cavities.resize(estimators::StateMessage::kMaxCavities, message.cavities[0]);
  for (std::size_t k = 0; k < message.cavities.size(); ++k)
    message.cavities[k].peer = static_cast<AgentId>(k);
  const auto back = codec::round_trip(header, message);
  ASSERT_TRUE(back.well_formed);
  expect_cavities_bit_exact(back.message.cavities, message.cavities);
  message.cavities.push_back(message.cavities[0]);
  EXPECT_THROW((void)codec::round_trip(header, message), DdsError);
}

TEST(ConvertCavities, HostileCavitiesAreMalformedAndCountedSo) {
  const auto header = test::make_header(2, 0);
  const auto planar = planar_state_with_cavities();
  const auto spatial = spatial_state_with_cavities();
  const std::vector<double> three_z{0.5, -0.5, 0.25};
  // The hostile writer's path itself carries good cavities.
  ASSERT_TRUE(codec::round_trip_with_cavities(header, planar, planar.cavities, {}).well_formed);
  const auto carried = codec::round_trip_with_cavities(header, spatial, spatial.cavities, three_z);
  ASSERT_TRUE(carried.well_formed);
  EXPECT_EQ(carried.message.cavities[2].offset_z_m, 0.25);

  struct Case {
    const char* name;
    const estimators::StateMessage* message;
    std::vector<estimators::EdgeCavity> cavities;
    std::vector<double> offset_z;
  };
  const auto spoiled = [](const estimators::StateMessage& message, void (*spoil)(estimators::EdgeCavity&)) {
    auto cavities = message.cavities;
    spoil(cavities[1]);
    return cavities;
  };
  const Case cases[] = {
      {"NaN offset x", &planar, spoiled(planar, [](auto& c) { c.offset_m.x() = kCavityNan; }), {}},
      {"-Inf offset y", &planar, spoiled(planar, [](auto& c) { c.offset_m.y() = -kCavityInf; }), {}},
      {"NaN variance", &planar, spoiled(planar, [](auto& c) { c.variance_m2 = -kCavityNan; }), {}},
      {"+Inf variance", &planar, spoiled(planar, [](auto& c) { c.variance_m2 = kCavityInf; }), {}},
      {"negative variance", &planar, spoiled(planar, [](auto& c) { c.variance_m2 = -1e-300; }), {}},
      {"NaN offset z", &spatial, spatial.cavities, {0.5, kCavityNan, 0.25}},
      {"+Inf offset z", &spatial, spatial.cavities, {kCavityInf, -0.5, 0.25}},
      {"65 cavities", &planar, std::vector<estimators::EdgeCavity>(65, planar.cavities[0]), {}},
      {"65 cavities and 65 offset z's", &spatial,
       std::vector<estimators::EdgeCavity>(65, spatial.cavities[0]), std::vector<double>(65, 0.5)},
      {"one offset z too few", &spatial, spatial.cavities, {0.5, -0.5}},
      {"one offset z too many", &spatial, spatial.cavities, {0.5, -0.5, 0.25, 1.0}},
      {"3-D without offset z's", &spatial, spatial.cavities, {}},
      {"planar with offset z's", &planar, planar.cavities, three_z},
  };
  auto agent = cavity_runtime();
  std::uint32_t seq = 0;
  for (const auto& c : cases) {
    const auto back = codec::round_trip_with_cavities(header, *c.message, c.cavities, c.offset_z);
    EXPECT_FALSE(back.well_formed) << c.name;
    EXPECT_FALSE(agent.on_state(test::make_header(2, seq++), back.message, back.well_formed)) << c.name;
  }
  const auto& reasons = agent.rejected_by_reason();
  EXPECT_EQ(reasons[static_cast<std::size_t>(runtime::RejectReason::kMalformed)], std::size(cases));
  EXPECT_EQ(std::accumulate(reasons.begin(), reasons.end(), std::uint64_t{0}), std::size(cases));
}

}  // namespace
}  // namespace swarmloc::dds
