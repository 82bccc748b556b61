#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "swarmloc/research/sdp_refinement.hpp"

namespace swarmloc::research {
namespace {

TEST(GeometricGraph, IsConnectedWithEnoughRangesPerUnknownAndNoisyRanges) {
  GeometricGraphConfig config;
  config.anchors = 5;
  config.noise_factor = 0.1;
  std::mt19937_64 rng(3);
  const LatticeProblem world = make_geometric_graph_problem(config, rng);
  ASSERT_EQ(world.truth.size(), 50U);
  int anchors = 0;
  std::vector<int> degree(50, 0);
  double relative_error = 0.0;
  for (const auto& e : world.problem.edges) {
    const double d =
        (world.truth[static_cast<std::size_t>(e.i)] - world.truth[static_cast<std::size_t>(e.j)]).norm();
    EXPECT_LT(d, config.radius);
    relative_error += std::pow((e.range_m - d) / d, 2);
    ++degree[static_cast<std::size_t>(e.i)];
    ++degree[static_cast<std::size_t>(e.j)];
  }
  for (std::size_t i = 0; i < 50; ++i) {
    if (world.problem.anchor[i]) {
      ++anchors;
      EXPECT_EQ(world.problem.initial[i], world.truth[i]);
    } else {
      EXPECT_GE(degree[i], config.min_unknown_degree);
    }
  }
  EXPECT_EQ(anchors, 5);
  // std of (d̄ − d)/d is ν_d = 0.1 (eq. (16)); the fold |·| hardly matters at 10 %.
  EXPECT_NEAR(std::sqrt(relative_error / static_cast<double>(world.problem.edges.size())), 0.1, 0.02);
}

TEST(AsynchronousStart, EqualStartTicksReproduceTheSynchronousRunExactly) {
  GeometricGraphConfig config;
  config.nodes = 15;
  config.radius = 0.5;
  config.noise_factor = 0.05;
  std::mt19937_64 rng(4);
  const SdpInstance instance = make_sdp_instance(config, rng);
  ASSERT_TRUE(instance.sdp.usable());
  const auto params = example3_dgbb_params();
  const GradientRun sync = run_gradient_agents(instance.world, params);
  const GradientRun shifted =
      run_gradient_agents(instance.world, params, false, std::vector<std::int64_t>(15, 7));
  EXPECT_EQ(shifted.final_error, sync.final_error);
  EXPECT_EQ(shifted.tau_end, sync.tau_end);
  EXPECT_EQ(shifted.rounds, sync.rounds + 7);
  EXPECT_THROW(run_gradient_agents(instance.world, params, false, {1, 2}), std::invalid_argument);
}

// Small seeded Table II: 30 nodes with R = 0.4 (about the mean degree of n = 50, R = 0.3), 5 anchors.
TEST(SdpRefinementExperiment, DistributedGradientImprovesOnTheSdpInitialGuess) {
  TableTwoConfig config;
  config.nodes = 30;
  config.radius = 0.4;
  config.anchors = {5};
  config.noise_factors = {0.05, 0.1};
  config.runs = 2;
  config.seed = 2;
  config.threads = 2;
  const auto table = run_table_two(config, example3_dgbb_params());
  ASSERT_EQ(table.size(), 2U);
  for (const TableTwoCell& cell : table) {
    EXPECT_EQ(cell.sdp_failures, 0);
    EXPECT_EQ(cell.runs, 2);
    EXPECT_GT(cell.sdp_error, 0.0);
    EXPECT_LT(cell.refined_error, cell.sdp_error) << "ν_d = " << cell.noise_factor;
    EXPECT_EQ(cell.tau_max_reached, 0);
  }
}

// Small Table III: the same worlds, nodes start at t_i ~ U{0, …, 30} ticks (about 1.5 DG-BB updates of
// skew) and still converge to within 1.3× the synchronous Φ.
TEST(SdpRefinementExperiment, AsynchronousStartConvergesCloseToTheSynchronousError) {
  TableThreeConfig config;
  config.nodes = 30;
  config.radius = 0.4;
  config.anchors = 5;
  config.max_skews = {30};
  config.runs = 2;
  config.seed = 2;
  config.threads = 2;
  const auto table = run_table_three(config, example3_dgbb_params());
  ASSERT_EQ(table.size(), 2U);
  EXPECT_EQ(table[0].max_skew, 0);
  EXPECT_EQ(table[1].max_skew, 30);
  EXPECT_EQ(table[1].runs, 2);
  EXPECT_LT(table[0].refined_error, table[0].sdp_error);
  EXPECT_LT(table[1].refined_error, 1.3 * table[0].refined_error);
  EXPECT_EQ(table[1].tau_max_reached, 0);
  // Nodes out of phase need more updates than the synchronous run, but finish.
  EXPECT_GT(table[1].mean_tau_end, table[0].mean_tau_end);
  EXPECT_EQ(table[0].sdp_error, table[1].sdp_error);  // one SDP per run, shared by the columns
}

}  // namespace
}  // namespace swarmloc::research
