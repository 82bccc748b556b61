// The UWB team's samples (idl/uwb_team.idl): exact round trips, and every hostile sample refused with the
// rule it broke. Through the IDL-free codec face (the generated uwb_team.h is private to swarmloc_dds).
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "../../../common/dds/src/uwb_team_codec.hpp"
#include "swarmloc/dds/transport.hpp"

namespace swarmloc::dds {
namespace {

namespace uwb = estimators::uwb;
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
const std::vector<AgentId> kUwbTeam{1, 2, 3};

/// Bitwise equality with NaN equal to NaN (a missing range stays missing).
void expect_same(const MatX& a, const MatX& b) {
  ASSERT_EQ(a.rows(), b.rows());
  ASSERT_EQ(a.cols(), b.cols());
  for (Eigen::Index k = 0; k < a.size(); ++k) {
    if (std::isnan(a.data()[k])) {
      EXPECT_TRUE(std::isnan(b.data()[k])) << k;
    } else {
      EXPECT_EQ(a.data()[k], b.data()[k]) << k;
    }
  }
}

MatX ranges_3x2(double offset) {
  MatX ranges(3, 2);  // not square: rows and columns must not be swapped
  ranges << 4.25 + offset, kNan, 1.0 / 3.0, 5.5, 6.0 + offset, 1e-3;
  return ranges;
}

UwbWindowInput make_input() {
  UwbWindowInput input;
  input.vehicle = 2;
  input.window = 41;
  input.time_s = 40.0 + 1.0 / 7.0;
  input.dt_s = 1.0 / 3.0;
  input.sensing = uwb::VehicleSensing{{0.1, -1.0 / 9.0}, -0.25, 1.75};
  MatX spread(3, 2);
  spread << 0.01, kNan, 0.0, 0.2, 1.0 / 11.0, 0.5;
  input.ranges = {{1, ranges_3x2(0.0), spread}, {3, ranges_3x2(1.0), MatX()}};
  return input;
}

uwb::PoseEstimate make_estimate(double offset) {
  uwb::PoseEstimate estimate;
  estimate.pose = {Vec3(1.0 / 3.0 + offset, -2.5, 0.125), 3.0};
  uwb::Mat4 a = uwb::Mat4::Random();
  estimate.covariance = a * a.transpose() + uwb::Mat4::Identity() * 1e-3;  // symmetric to rounding only
  return estimate;
}

UwbEstimates make_estimates() {
  return {1, 41, UwbRound::kOwn, {{2, make_estimate(0.0)}, {3, make_estimate(1.0)}}};
}

TEST(UwbTeamCodec, WindowInputRoundTripsExactlyWithItsMissingRanges) {
  const auto input = make_input();
  const auto back = uwb_codec::round_trip(input, kUwbTeam);
  ASSERT_EQ(back.problem, nullptr) << back.problem;
  ASSERT_TRUE(back.value);
  EXPECT_EQ(back.value->vehicle, 2);
  EXPECT_EQ(back.value->window, 41);
  EXPECT_EQ(back.value->time_s, input.time_s);
  EXPECT_EQ(back.value->dt_s, input.dt_s);
  EXPECT_FALSE(back.value->stop);
  ASSERT_TRUE(back.value->sensing);
  EXPECT_EQ(back.value->sensing->tilt.pitch_rad, -1.0 / 9.0);
  EXPECT_EQ(back.value->sensing->altitude_m, 1.75);
  ASSERT_EQ(back.value->ranges.size(), 2U);
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(back.value->ranges[k].peer, input.ranges[k].peer);
    expect_same(back.value->ranges[k].ranges_m, input.ranges[k].ranges_m);
    expect_same(back.value->ranges[k].spread_m, input.ranges[k].spread_m);
  }
}

TEST(UwbTeamCodec, SensingWithoutAltitudeOrReadingRoundTrips) {
  UwbSensing sensing{3, 7, uwb::VehicleSensing{{-0.5, 0.25}, 1.0 / 3.0, std::nullopt}};
  auto back = uwb_codec::round_trip(sensing, kUwbTeam);
  ASSERT_TRUE(back.value) << back.problem;
  EXPECT_EQ(back.value->sensing->turn_rad, 1.0 / 3.0);
  EXPECT_FALSE(back.value->sensing->altitude_m);
  sensing.sensing.reset();
  back = uwb_codec::round_trip(sensing, kUwbTeam);
  ASSERT_TRUE(back.value) << back.problem;
  EXPECT_FALSE(back.value->sensing);
}

TEST(UwbTeamCodec, EstimatesRoundTripExactlyAndAHelloIsEmpty) {
  const auto estimates = make_estimates();
  const auto back = uwb_codec::round_trip(estimates, kUwbTeam);
  ASSERT_TRUE(back.value) << back.problem;
  EXPECT_EQ(back.value->round, UwbRound::kOwn);
  ASSERT_EQ(back.value->peers.size(), 2U);
  for (const auto& [peer, estimate] : estimates.peers) {
    const auto& got = back.value->peers.at(peer);
    EXPECT_EQ(got.pose.vector(), estimate.pose.vector());
    EXPECT_EQ(got.covariance, estimate.covariance);
  }
  EXPECT_TRUE(uwb_codec::round_trip(UwbEstimates{2, -1, UwbRound::kHello, {}}, kUwbTeam).value);
}

/// One hostile mutation of a valid sample and the rule that must refuse it.
template <typename Sample>
struct Hostile {
  std::string what;
  std::string rule;
  std::function<void(Sample&)> mutate;
};

template <typename Sample>
void expect_all_refused(const Sample& valid, const std::vector<Hostile<Sample>>& cases) {
  ASSERT_TRUE(uwb_codec::round_trip(valid, kUwbTeam).value);
  for (const auto& hostile : cases) {
    Sample sample = valid;
    hostile.mutate(sample);
    const auto back = uwb_codec::round_trip(sample, kUwbTeam);
    EXPECT_FALSE(back.value) << hostile.what;
    EXPECT_EQ(std::string(back.problem ? back.problem : "accepted"), hostile.rule) << hostile.what;
  }
}

TEST(UwbTeamCodec, HostileWindowInputsAreRefused) {
  using Input = UwbWindowInput;
  expect_all_refused<Input>(
      make_input(),
      {{"vehicle off the team", "unknown vehicle", [](Input& s) { s.vehicle = 9; }},
       {"peer off the team", "unknown peer", [](Input& s) { s.ranges[0].peer = 4; }},
       {"ranges to itself", "unknown peer", [](Input& s) { s.ranges[0].peer = 2; }},
       {"duplicate peer", "duplicate peer", [](Input& s) { s.ranges[1].peer = 1; }},
       {"infinite range", "range out of bounds", [](Input& s) { s.ranges[0].ranges_m(0, 0) = kInf; }},
       {"negative range", "range out of bounds", [](Input& s) { s.ranges[0].ranges_m(2, 1) = -1.0; }},
       {"zero range", "range out of bounds", [](Input& s) { s.ranges[1].ranges_m(1, 0) = 0.0; }},
       {"absurd range", "range out of bounds", [](Input& s) { s.ranges[1].ranges_m(1, 0) = 1e9; }},
       {"negative spread", "spread out of bounds", [](Input& s) { s.ranges[0].spread_m(0, 0) = -0.1; }},
       {"infinite spread", "spread out of bounds", [](Input& s) { s.ranges[0].spread_m(1, 1) = kInf; }},
       {"NaN roll", "non-finite or absurd reading", [](Input& s) { s.sensing->tilt.roll_rad = kNan; }},
       {"absurd turn", "non-finite or absurd reading", [](Input& s) { s.sensing->turn_rad = 1e6; }},
       {"infinite altitude", "non-finite or absurd reading", [](Input& s) { s.sensing->altitude_m = kInf; }},
       {"NaN dt", "bad window or time", [](Input& s) { s.dt_s = kNan; }},
       {"negative dt", "bad window or time", [](Input& s) { s.dt_s = -1.0; }},
       {"NaN time", "bad window or time", [](Input& s) { s.time_s = kNan; }},
       {"negative window", "bad window or time", [](Input& s) { s.window = -1; }},
       {"stop with data", "stop with data", [](Input& s) { s.stop = true; }}});
}

TEST(UwbTeamCodec, HostileSensingIsRefused) {
  using Sensing = UwbSensing;
  expect_all_refused<Sensing>(
      UwbSensing{3, 7, uwb::VehicleSensing{{0.0, 0.0}, 0.0, 1.0}},
      {{"vehicle off the team", "unknown vehicle", [](Sensing& s) { s.vehicle = 0; }},
       {"negative window", "bad window or time", [](Sensing& s) { s.window = -3; }},
       {"infinite pitch", "non-finite or absurd reading",
        [](Sensing& s) { s.sensing->tilt.pitch_rad = -kInf; }},
       {"NaN altitude", "non-finite or absurd reading", [](Sensing& s) { s.sensing->altitude_m = kNan; }}});
}

TEST(UwbTeamCodec, HostileEstimatesAreRefused) {
  using Estimates = UwbEstimates;
  expect_all_refused<Estimates>(
      make_estimates(),
      {{"vehicle off the team", "unknown vehicle", [](Estimates& s) { s.vehicle = 5; }},
       {"peer off the team", "unknown peer", [](Estimates& s) { s.peers[7] = make_estimate(0.0); }},
       {"estimate of itself", "unknown peer", [](Estimates& s) { s.peers[1] = make_estimate(0.0); }},
       {"NaN position", "non-finite or absurd pose",
        [](Estimates& s) { s.peers[2].pose.position_m.y() = kNan; }},
       {"absurd position", "non-finite or absurd pose",
        [](Estimates& s) { s.peers[2].pose.position_m.x() = 1e7; }},
       {"infinite heading", "non-finite or absurd pose",
        [](Estimates& s) { s.peers[3].pose.heading_rad = kInf; }},
       {"NaN covariance", "non-finite covariance", [](Estimates& s) { s.peers[3].covariance(3, 3) = kNan; }},
       {"non-symmetric covariance", "non-symmetric covariance",
        [](Estimates& s) { s.peers[2].covariance(0, 2) += 0.5; }},
       {"negative variance", "negative variance", [](Estimates& s) { s.peers[2].covariance(1, 1) = -1.0; }},
       {"own round with window -1", "bad window or time", [](Estimates& s) { s.window = -1; }},
       {"hello with estimates", "bad window or time", [](Estimates& s) { s.round = UwbRound::kHello; }},
       {"hello with estimates", "hello with estimates",
        [](Estimates& s) {
          s.round = UwbRound::kHello;
          s.window = -1;
        }},
       {"hello of a window", "bad window or time", [](Estimates& s) {
          s.round = UwbRound::kHello;
          s.peers.clear();
        }}});
}

TEST(UwbTeamCodec, WireSizesAndRoundsAreChecked) {
  const std::vector<double> six(6, 1.0);
  uwb::PeerRanges out;
  EXPECT_EQ(uwb_codec::decode_range_window(2, 3, 2, six, {}, out), nullptr);
  EXPECT_EQ(out.ranges_m.rows(), 3);
  EXPECT_NE(uwb_codec::decode_range_window(2, 2, 2, six, {}, out), nullptr);  // 4 entries claimed, 6 sent
  EXPECT_NE(uwb_codec::decode_range_window(2, 3, 2, six, std::span(six).first(5), out), nullptr);
  EXPECT_NE(uwb_codec::decode_range_window(2, 0, 0, {}, {}, out), nullptr);
  const std::vector<double> eighty_one(81, 1.0);
  EXPECT_NE(uwb_codec::decode_range_window(2, 9, 9, eighty_one, {}, out), nullptr);
  UwbRound round = UwbRound::kOwn;
  EXPECT_EQ(uwb_codec::decode_round(2, round), nullptr);
  EXPECT_EQ(round, UwbRound::kFused);
  EXPECT_NE(uwb_codec::decode_round(3, round), nullptr);
}

TEST(UwbTeamCodec, SamplesBeyondTheIdlBoundsAreNotWritten) {
  auto input = make_input();
  input.ranges[0].ranges_m = MatX::Constant(9, 9, 1.0);
  input.ranges[0].spread_m = MatX();
  EXPECT_THROW((void)uwb_codec::round_trip(input, kUwbTeam), DdsError);
  auto estimates = make_estimates();
  for (AgentId peer = 10; peer < 17; ++peer) estimates.peers[peer] = make_estimate(0.0);
  EXPECT_THROW((void)uwb_codec::round_trip(estimates, kUwbTeam), DdsError);
}

}  // namespace
}  // namespace swarmloc::dds
