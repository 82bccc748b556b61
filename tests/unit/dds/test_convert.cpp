// IDL <-> swarmloc conversion: exact round trips for every family and malformed-sample detection.
// The generated swarmloc.h is private to swarmloc_dds, so these go through the IDL-free codec face.
#include <gtest/gtest.h>

#include <limits>

#include "../../../common/dds/src/wire_codec.hpp"
#include "dds_test_support.hpp"
#include "observation_sample.hpp"

namespace swarmloc::dds {
namespace {

using test::expect_header_eq;

TEST(Convert, StateRoundTripsExactly) {
  const auto header = test::make_header(4, 17);
  for (const bool anchor : {false, true}) {
    for (const bool active : {false, true}) {
      auto message = test::make_state(0.0);
      message.anchor = anchor;
      message.active = active;
      const auto back = codec::round_trip(header, message);
      EXPECT_TRUE(back.well_formed);
      expect_header_eq(back.header, header);
      test::expect_state_eq(back.message, message);
    }
  }
}

TEST(Convert, StateEdgeRangesRoundTripAndAbsurdOnesAreRefused) {
  const auto header = test::make_header(4, 17);
  auto message = test::make_state(0.0);
  message.edge_ranges = {{3, 1e4, 12.25}, {-1, 0.0, 0.5}};
  const auto back = codec::round_trip(header, message);
  ASSERT_TRUE(back.well_formed);
  ASSERT_EQ(back.message.edge_ranges.size(), 2U);
  EXPECT_EQ(back.message.edge_ranges[0].peer, 3);
  EXPECT_EQ(back.message.edge_ranges[0].information, 1e4);
  EXPECT_EQ(back.message.edge_ranges[0].mean_range_m, 12.25);
  EXPECT_EQ(back.message.edge_ranges[1].peer, -1);
  for (const double bad : {std::numeric_limits<double>::quiet_NaN(), -1.0}) {
    auto hostile = message;
    hostile.edge_ranges[1].information = bad;
    EXPECT_FALSE(codec::round_trip(header, hostile).well_formed) << bad;
  }
  message.edge_ranges.resize(17);
  EXPECT_THROW((void)codec::round_trip(header, message), DdsError);
}

TEST(Convert, Sym2IsTheUpperTriangleXxXyYy) {
  const auto packed = codec::pack_sym2(test::sym2(1.0, 2.0, 3.0));
  EXPECT_EQ(packed, (std::array<double, 3>{1.0, 2.0, 3.0}));
  const Mat2 unpacked = codec::unpack_sym2(std::span<const double, 3>(packed));
  EXPECT_EQ(unpacked(1, 0), 2.0);
  EXPECT_EQ(unpacked(0, 1), 2.0);
}

TEST(Convert, InformationWithFourStatesRoundTripsExactly) {
  const auto header = test::make_header(2, 5);
  const auto message = test::make_information(4);
  const auto back = codec::round_trip(header, message);
  EXPECT_TRUE(back.well_formed);
  expect_header_eq(back.header, header);
  test::expect_information_eq(back.message, message);
}

TEST(Convert, InformationOfDimensionZeroAndSixtyFourRoundTrip) {
  for (const int n : {0, 1, 64}) {
    const auto message = test::make_information(n);
    const auto back = codec::round_trip(test::make_header(1, 0), message);
    EXPECT_TRUE(back.well_formed) << "n=" << n;
    test::expect_information_eq(back.message, message);
  }
}

TEST(Convert, InformationBeyondTheIdlBoundOrWithMismatchedMatrixIsRefusedOnWrite) {
  EXPECT_THROW(codec::round_trip(test::make_header(1, 0), test::make_information(65)), DdsError);
  auto bad = test::make_information(4);
  bad.info_mat = MatX::Identity(3, 3);
  EXPECT_THROW(codec::round_trip(test::make_header(1, 0), bad), DdsError);
}

TEST(Convert, InformationWithWrongMatrixSizeIsMalformed) {
  const auto header = test::make_header(6, 1);
  const std::vector<double> vec(4, 1.0);
  const std::vector<double> ok(10, 0.5);  // 4 * 5 / 2
  EXPECT_TRUE(codec::decode_information_fields(header, 6, 0, vec, ok).well_formed);
  for (const std::size_t size : {0U, 9U, 11U, 16U}) {
    const std::vector<double> mat(size, 0.5);
    EXPECT_FALSE(codec::decode_information_fields(header, 6, 0, vec, mat).well_formed) << "size " << size;
  }
}

TEST(Convert, InformationLongerThanItsBoundIsMalformed) {
  const auto header = test::make_header(6, 1);
  const std::vector<double> vec(65, 1.0);
  const std::vector<double> mat(65 * 66 / 2, 1.0);
  EXPECT_FALSE(codec::decode_information_fields(header, 6, 0, vec, mat).well_formed);
}

TEST(Convert, KeyThatDisagreesWithTheHeaderSenderIsMalformed) {
  const std::vector<double> vec(1, 1.0);
  const std::vector<double> mat(1, 1.0);
  EXPECT_FALSE(codec::decode_information_fields(test::make_header(6, 1), 7, 0, vec, mat).well_formed);
}

TEST(Convert, UpperTriangleUnpacksSymmetric) {
  const std::vector<double> packed = {1, 2, 3, 4, 5, 6};  // 3x3
  const auto m = codec::unpack_upper(packed, 3);
  ASSERT_TRUE(m.has_value());
  MatX expected(3, 3);
  expected << 1, 2, 3, 2, 4, 5, 3, 5, 6;
  EXPECT_MATRIX_NEAR(*m, expected, 0.0);
  EXPECT_EQ(codec::pack_upper(expected), packed);
  EXPECT_FALSE(codec::unpack_upper(packed, 2).has_value());
}

TEST(Convert, UnknownStateFlagBitsAreMalformed) {
  estimators::StateMessage message;
  EXPECT_TRUE(codec::apply_state_flags(3, message));
  EXPECT_TRUE(message.anchor);
  EXPECT_TRUE(message.active);
  EXPECT_FALSE(message.inconsistent);
  EXPECT_TRUE(codec::apply_state_flags(6, message));
  EXPECT_FALSE(message.anchor);
  EXPECT_TRUE(message.inconsistent);
  EXPECT_EQ(codec::state_flags(message), 6);
  EXPECT_FALSE(codec::apply_state_flags(8, message));
  EXPECT_FALSE(codec::apply_state_flags(0x83, message));
}

TEST(Convert, ControlCommandsOutOfRangeAreMalformed) {
  EXPECT_EQ(codec::control_command(0), runtime::ControlCommand::kHello);
  EXPECT_EQ(codec::control_command(1), runtime::ControlCommand::kStart);
  EXPECT_EQ(codec::control_command(2), runtime::ControlCommand::kStop);
  EXPECT_EQ(codec::control_command(3), runtime::ControlCommand::kRefuse);
  EXPECT_FALSE(codec::control_command(4).has_value());
  EXPECT_FALSE(codec::control_command(255).has_value());
}

TEST(Convert, ConsensusRoundTripsExactly) {
  const auto header = test::make_header(9, 3);
  const auto message = test::make_consensus();
  const auto back = codec::round_trip(header, message);
  EXPECT_TRUE(back.well_formed);
  expect_header_eq(back.header, header);
  EXPECT_EQ(back.message.tau, message.tau);
  EXPECT_EQ(back.message.round, message.round);
  EXPECT_EQ(back.message.values, message.values);
  auto too_many = message;
  too_many.values.assign(17, 1.0);
  EXPECT_THROW(codec::round_trip(header, too_many), DdsError);
}

TEST(Convert, BeliefRoundTripsExactly) {
  const auto header = test::make_header(0, 0);
  const auto message = test::make_belief();
  const auto back = codec::round_trip(header, message);
  EXPECT_TRUE(back.well_formed);
  expect_header_eq(back.header, header);
  EXPECT_EQ(back.message.iteration, message.iteration);
  EXPECT_MATRIX_NEAR(back.message.mean_m, message.mean_m, 0.0);
  EXPECT_MATRIX_NEAR(back.message.information, message.information, 0.0);
  EXPECT_EQ(back.message.infinite_information, message.infinite_information);
  ASSERT_EQ(back.message.contributions.size(), message.contributions.size());
  for (std::size_t k = 0; k < message.contributions.size(); ++k) {
    EXPECT_EQ(back.message.contributions[k].from, message.contributions[k].from);
    EXPECT_MATRIX_NEAR(back.message.contributions[k].information, message.contributions[k].information, 0.0);
    EXPECT_MATRIX_NEAR(back.message.contributions[k].info_vec, message.contributions[k].info_vec, 0.0);
  }
  auto too_many = message;
  too_many.contributions.resize(codec::kMaxBeliefContributions + 1);
  EXPECT_THROW(codec::round_trip(header, too_many), DdsError);
}

TEST(Convert, NonFiniteValuesPassThroughForTheRuntimeToJudge) {
  auto message = test::make_state(0.0);
  message.mean_m.x() = std::numeric_limits<double>::quiet_NaN();
  message.covariance(0, 0) = std::numeric_limits<double>::infinity();
  const auto back = codec::round_trip(test::make_header(1, 1), message);
  EXPECT_TRUE(back.well_formed);
  EXPECT_TRUE(std::isnan(back.message.mean_m.x()));
  EXPECT_TRUE(std::isinf(back.message.covariance(0, 0)));
}

TEST(Convert, MeasurementBatchRoundTripsExactly) {
  const auto header = test::make_header(kOrchestratorId, 8);
  auto batch = test::make_batch(header.step, header.world_stamp_ns);
  const auto back = codec::round_trip(5, header, batch);
  EXPECT_TRUE(back.well_formed);
  EXPECT_EQ(back.recipient, 5);
  expect_header_eq(back.header, header);
  test::expect_batch_eq(back.batch, batch);

  batch.fix.reset();
  batch.motion.reset();
  batch.ranges.clear();
  batch.neighbours.clear();
  batch.bearings.clear();
  batch.relative.clear();
  batch.targets.clear();
  batch.paths.clear();
  const auto empty = codec::round_trip(5, header, batch);
  EXPECT_TRUE(empty.well_formed);
  test::expect_batch_eq(empty.batch, batch);
}

TEST(Convert, EstimateWithLinkCountersRoundTripsExactly) {
  const auto report = test::make_estimate(11, 2);
  const auto back = codec::round_trip(report);
  EXPECT_TRUE(back.well_formed);
  test::expect_estimate_eq(back.report, report);
}

TEST(Convert, ControlRoundTripsExactly) {
  runtime::ControlMessage message;
  message.header = test::make_header(kOrchestratorId, 1);
  message.target = kOrchestratorId;
  message.command = runtime::ControlCommand::kStop;
  message.scenario_hash = 0xfedcba9876543210ULL;
  message.start_world_ns = 5'000'000'000LL;
  const auto back = codec::round_trip(message);
  EXPECT_TRUE(back.well_formed);
  expect_header_eq(back.message.header, message.header);
  EXPECT_EQ(back.message.target, message.target);
  EXPECT_EQ(back.message.command, message.command);
  EXPECT_EQ(back.message.scenario_hash, message.scenario_hash);
  EXPECT_EQ(back.message.start_world_ns, message.start_world_ns);
}

TEST(Convert, EstimateCarriesTheSelfCheckVerdict) {
  for (const bool inconsistent : {false, true}) {
    runtime::EstimateReport report;
    report.header = test::make_header(2, 5);
    report.estimate.valid = true;
    report.estimate.inconsistent = inconsistent;
    const auto back = codec::round_trip(report);
    ASSERT_TRUE(back.well_formed);
    EXPECT_EQ(back.report.estimate.inconsistent, inconsistent);
    EXPECT_TRUE(back.report.estimate.valid);
  }
}

TEST(Convert, ObservationsRoundTripExactly) {
  const auto header = test::make_header(3, 12);
  const auto message = swarmloc::test::observation_sample();
  const auto back = codec::round_trip(header, message);
  ASSERT_TRUE(back.well_formed);
  expect_header_eq(back.header, header);
  EXPECT_EQ(back.message.origin_step, message.origin_step);
  EXPECT_MATRIX_NEAR(back.message.origin_pose, message.origin_pose, 0.0);
  EXPECT_MATRIX_NEAR(back.message.origin_covariance, message.origin_covariance, 0.0);
  ASSERT_EQ(back.message.spans.size(), 2U);
  for (std::size_t k = 0; k < 2; ++k) {
    const auto& sent = message.spans[k];
    const auto& got = back.message.spans[k];
    EXPECT_EQ(got.first_world_step, sent.first_world_step);
    EXPECT_EQ(got.world_step, sent.world_step);
    EXPECT_EQ(got.world_time_s, sent.world_time_s);
    ASSERT_EQ(got.odometry.has_value(), sent.odometry.has_value());
    ASSERT_EQ(got.range_bearings.size(), sent.range_bearings.size());
  }
  const auto& odometry = *back.message.spans[0].odometry;
  EXPECT_EQ(odometry.v_std, 0.011);
  EXPECT_EQ(odometry.omega_std, 0.038);
  ASSERT_EQ(odometry.segments.size(), 2U);
  EXPECT_EQ(odometry.segments[1].v_mps, 0.25);
  EXPECT_EQ(odometry.segments[1].omega_radps, 0.05);
  EXPECT_EQ(odometry.segments[1].dt_s, 0.085);
  const auto& landmark = back.message.spans[0].range_bearings[0];
  EXPECT_TRUE(landmark.landmark);
  EXPECT_MATRIX_NEAR(landmark.landmark_m, Vec2(4.5, -1.0), 0.0);
  EXPECT_MATRIX_NEAR(landmark.landmark_cov, message.spans[0].range_bearings[0].landmark_cov, 0.0);
  EXPECT_EQ(landmark.range_m, 2.25);
  EXPECT_EQ(landmark.bearing_std_rad, 0.01);
  EXPECT_EQ(landmark.age_s, 0.035);
  const auto& robot = back.message.spans[0].range_bearings[1];
  EXPECT_FALSE(robot.landmark);
  EXPECT_EQ(robot.peer, 4);
  EXPECT_EQ(robot.bearing_rad, 3.0);

  auto too_many = message;
  too_many.spans.resize(codec::kMaxObservedSpans + 1);
  EXPECT_THROW(codec::round_trip(header, too_many), DdsError);
}

TEST(Convert, EstimateCarriesThePoseHeadingOrNone) {
  runtime::EstimateReport report;
  report.header = test::make_header(2, 5);
  report.estimate.valid = true;
  const auto without = codec::round_trip(report);
  ASSERT_TRUE(without.well_formed);
  EXPECT_FALSE(without.report.estimate.heading.has_value());
  report.estimate.heading = estimators::HeadingEstimate{-3.0, 2.5e-4, Vec2(1e-5, -2e-5)};
  const auto with = codec::round_trip(report);
  ASSERT_TRUE(with.well_formed);
  ASSERT_TRUE(with.report.estimate.heading.has_value());
  EXPECT_EQ(with.report.estimate.heading->heading_rad, -3.0);
  EXPECT_EQ(with.report.estimate.heading->variance_rad2, 2.5e-4);
  EXPECT_MATRIX_NEAR(with.report.estimate.heading->position_cov_m_rad, Vec2(1e-5, -2e-5), 0.0);
  report.estimate.heading->variance_rad2 = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(codec::round_trip(report).well_formed);
}

}  // namespace
}  // namespace swarmloc::dds
