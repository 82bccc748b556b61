// The shared runtime with the Atanasov et al., Leng et al. and Calafiore et al. estimators: validation of the
// information, consensus and belief families, and batches that supersede each other.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "eigen_gtest.hpp"
#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/runtime/agent_factory.hpp"
#include "swarmloc/runtime/agent_runtime.hpp"
#include "swarmloc/runtime/manifest.hpp"

namespace swarmloc::runtime {
namespace {

const std::string kScenarios = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/";

config::Scenario scenario_named(const std::string& file, const std::vector<std::string>& overrides = {}) {
  return config::load_scenario(kScenarios + file, overrides);
}

/// Agent 0 of the multipath scenario at (5, 5) with neighbours 1 and 2, as its manifest builds it.
AgentRuntime bp_runtime() {
  AgentManifest manifest;
  manifest.setup = estimators::AgentSetup{0, false, Vec2(5.0, 5.0)};
  manifest.neighbours = {1, 2};
  manifest.runtime.absurd_position_bound_m = 1e5;
  return make_agent_runtime(scenario_named("multipath_bp.yaml"), manifest);
}

TEST(CooperativeRuntime, HostileInformationConsensusAndBeliefSamplesAreRejectedPerReason) {
  AgentRuntime runtime = bp_runtime();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::uint32_t seq = 0;
  auto header = [&](AgentId sender) { return Header{sender, seq++, 0, 0, 0}; };

  estimators::BeliefMessage belief;
  belief.mean_m = Vec2(1.0, 2.0);
  belief.information = Mat2::Identity();
  EXPECT_TRUE(runtime.on_belief(header(1), belief));
  auto nan_belief = belief;
  nan_belief.mean_m.x() = nan;
  EXPECT_FALSE(runtime.on_belief(header(1), nan_belief));
  auto non_psd = belief;
  non_psd.information << 1.0, 3.0, 3.0, 1.0;
  EXPECT_FALSE(runtime.on_belief(header(1), non_psd));
  auto absurd = belief;
  absurd.mean_m = Vec2(1e9, 0.0);
  EXPECT_FALSE(runtime.on_belief(header(1), absurd));
  // Exact GaBP's contributions: each a PSD message, at most one per neighbour.
  auto with_contributions = belief;
  with_contributions.contributions = {{0, Mat2::Identity(), Vec2(1.0, 0.0)},
                                      {2, Mat2::Identity() * 0.5, Vec2::Zero()}};
  const std::uint32_t newest_from_1 = seq;
  EXPECT_TRUE(runtime.on_belief(header(1), with_contributions));
  auto nan_contribution = with_contributions;
  nan_contribution.contributions[1].info_vec.y() = nan;
  EXPECT_FALSE(runtime.on_belief(header(1), nan_contribution));
  auto non_psd_contribution = with_contributions;
  non_psd_contribution.contributions[0].information << 1.0, 3.0, 3.0, 1.0;
  EXPECT_FALSE(runtime.on_belief(header(1), non_psd_contribution));
  auto absurd_contribution = with_contributions;
  absurd_contribution.contributions[0].information *= 1e40;
  EXPECT_FALSE(runtime.on_belief(header(1), absurd_contribution));
  auto repeated = with_contributions;
  repeated.contributions[1].from = 0;
  EXPECT_FALSE(runtime.on_belief(header(1), repeated));
  auto negative_sender = with_contributions;
  negative_sender.contributions[0].from = -1;
  EXPECT_FALSE(runtime.on_belief(header(1), negative_sender));

  estimators::ConsensusMessage consensus;
  consensus.values = {1.0, 2.0};
  EXPECT_TRUE(runtime.on_consensus(header(2), consensus));
  auto inf_consensus = consensus;
  inf_consensus.values[1] = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(runtime.on_consensus(header(2), inf_consensus));
  auto long_consensus = consensus;
  long_consensus.values.assign(1000, 0.0);
  EXPECT_FALSE(runtime.on_consensus(header(2), long_consensus));
  auto negative_round = consensus;
  negative_round.round = -1;
  EXPECT_FALSE(runtime.on_consensus(header(2), negative_round));

  estimators::InformationMessage information;
  information.info_vec = VecX::Ones(2);
  information.info_mat = MatX::Identity(2, 2);
  EXPECT_TRUE(runtime.on_information(header(2), information));
  auto wrong_size = information;
  wrong_size.info_mat = MatX::Identity(3, 3);
  EXPECT_FALSE(runtime.on_information(header(2), wrong_size));
  auto negative_world_step = information;  // −1 means "none"; below it is malformed
  negative_world_step.world_step = -2;
  EXPECT_FALSE(runtime.on_information(header(2), negative_world_step));
  auto asymmetric = information;
  asymmetric.info_mat(0, 1) = 5.0;
  EXPECT_FALSE(runtime.on_information(header(2), asymmetric));
  EXPECT_FALSE(runtime.on_belief(header(7), belief)) << "agent 7 is not a neighbour";
  EXPECT_FALSE(runtime.on_belief(Header{1, newest_from_1, 0, 0, 0}, belief))
      << "the same seq as the newest from 1";
  EXPECT_FALSE(runtime.on_consensus(Header{2, 1, 0, 0, 0}, consensus)) << "older than the newest from 2";

  const auto& reasons = runtime.rejected_by_reason();
  auto count = [&](RejectReason r) { return reasons[static_cast<std::size_t>(r)]; };
  EXPECT_EQ(count(RejectReason::kNonFinite), 3U);
  EXPECT_EQ(count(RejectReason::kNotSymmetricPsd), 3U);
  EXPECT_EQ(count(RejectReason::kAbsurdMagnitude), 2U);
  EXPECT_EQ(count(RejectReason::kMalformed), 6U);
  EXPECT_EQ(count(RejectReason::kUnknownSender), 1U);
  EXPECT_EQ(count(RejectReason::kDuplicate), 1U);
  EXPECT_EQ(count(RejectReason::kReordered), 1U);
  // The runtime keeps stepping on the accepted samples only.
  const auto publication = runtime.step(0);
  ASSERT_TRUE(publication.outbox.belief.has_value());
  EXPECT_TRUE(publication.outbox.belief->mean_m.allFinite());
}

TEST(CooperativeRuntime, ASupersededBatchKeepsItsRelativeSamples) {
  // Free run: batches 0 and 1 both arrive before the agent steps. Jacobi from one anchor neighbour at
  // the origin gives x = −s̄, so the carried-over sample shows in the mean: s̄ = (1 + 3)/2, not 3.
  estimators::AgentSetup setup{0, false, Vec2(5.0, 5.0)};
  AgentRuntimeParams params;
  params.absurd_position_bound_m = 1e5;
  AgentRuntime runtime(config::make_estimator("jacobi", setup, {}), setup, {1}, params);
  estimators::StateMessage anchor;
  anchor.anchor = true;
  ASSERT_TRUE(runtime.on_state(Header{1, 0, 0, 0, 0}, anchor));
  for (const double sample : {1.0, 3.0}) {
    estimators::MeasurementBatch batch;
    batch.world_step = sample > 2.0 ? 1 : 0;
    batch.relative.push_back({1, Vec2(sample, 0.0), Mat2::Identity() * 0.01});
    batch.ranges.push_back({1, sample, 1.0});
    runtime.on_batch(Header{kOrchestratorId, 0, batch.world_step, 0, 0}, batch);
  }
  runtime.step(0);
  EXPECT_NEAR(runtime.estimate().mean_m.x(), -2.0, 1e-12);
  EXPECT_NEAR(runtime.estimate().mean_m.y(), 0.0, 1e-12);
}

TEST(CooperativeRuntime, ASupersededBatchKeepsItsTargetReadings) {
  // Free run: a static target's readings (1, 0) and (3, 0) arrive in batches 0 and 1 before the sensor
  // steps; the DLE sums both (equal weights): ŷ = (2, 0), not (3, 0).
  const estimators::AgentSetup setup{0, false, Vec2(5.0, 5.0)};
  AgentRuntimeParams params;
  params.absurd_position_bound_m = 1e5;
  AgentRuntime runtime(config::make_estimator("dle", setup, {}), setup, {}, params);
  for (const double reading : {1.0, 3.0}) {
    estimators::MeasurementBatch batch;
    batch.world_step = reading > 2.0 ? 1 : 0;
    batch.targets.push_back({0, Vec2(reading, 0.0), Mat2::Identity(), 0});
    runtime.on_batch(Header{kOrchestratorId, 0, batch.world_step, 0, 0}, batch);
  }
  runtime.step(0);
  EXPECT_NEAR(runtime.estimate().mean_m.x(), 2.0, 1e-12);
  EXPECT_NEAR(runtime.estimate().mean_m.y(), 0.0, 1e-12);
}
TEST(CooperativeRuntime, HostileObservationSamplesAreRejectedPerReasonAndGoodOnesKept) {
  AgentRuntime runtime = bp_runtime();
  std::uint32_t seq = 0;
  auto header = [&](AgentId sender) { return Header{sender, seq++, 0, 0, 0}; };
  estimators::ObservationMessage good;
  good.origin_step = 4;
  good.origin_pose = Eigen::Vector3d(1.0, 2.0, 0.5);
  good.origin_covariance = Eigen::Matrix3d::Identity() * 0.01;
  estimators::ObservedSteps span;
  span.first_world_step = 5, span.world_step = 6, span.world_time_s = 0.6;
  span.odometry = estimators::OdometryInput{{{0.2, 0.1, 0.1}}, 0.01, 0.04};
  good.spans = {span};
  EXPECT_TRUE(runtime.on_observations(header(1), good));
  const auto rejected = [&](const estimators::ObservationMessage& m, RejectReason reason) {
    const auto before = runtime.rejected_by_reason()[static_cast<std::size_t>(reason)];
    const bool stored = runtime.on_observations(header(1), m);
    return !stored && runtime.rejected_by_reason()[static_cast<std::size_t>(reason)] == before + 1;
  };
  auto gap = good;
  gap.spans[0].first_world_step = 6;  // step 5 neither in the span nor before the origin
  EXPECT_TRUE(rejected(gap, RejectReason::kMalformed));
  auto nan_pose = good;
  nan_pose.origin_pose.z() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(rejected(nan_pose, RejectReason::kNonFinite));
  auto nan_odometry = good;
  nan_odometry.spans[0].odometry->segments[0].dt_s = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(rejected(nan_odometry, RejectReason::kNonFinite));
  auto non_psd = good;
  non_psd.origin_covariance(0, 1) = non_psd.origin_covariance(1, 0) = 1.0;
  EXPECT_TRUE(rejected(non_psd, RejectReason::kNotSymmetricPsd));
  auto absurd = good;
  absurd.origin_pose.x() = 1e9;
  EXPECT_TRUE(rejected(absurd, RejectReason::kAbsurdMagnitude));
  auto too_many = good;
  too_many.spans.clear();
  for (int k = 0; k < 65; ++k) {
    too_many.spans.push_back(span);
    too_many.spans.back().first_world_step = too_many.spans.back().world_step = 5 + k;
  }
  EXPECT_TRUE(rejected(too_many, RejectReason::kMalformed));
}

}  // namespace
}  // namespace swarmloc::runtime
