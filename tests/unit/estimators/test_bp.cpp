#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "eigen_gtest.hpp"
#include "swarmloc/estimators/bp/multipath_bp.hpp"
#include "swarmloc/models/multipath.hpp"

namespace swarmloc::estimators::bp {
namespace {

// Two noise-free reflected paths between s_i and s_j (horizontal and 45° walls), as seen from S_i.
std::vector<MultipathMeasurement> two_paths(const Vec2& s_i, const Vec2& s_j, AgentId peer) {
  std::vector<MultipathMeasurement> out;
  const models::Wall walls[] = {{Vec2(5.0, -7.0), 0.0}, {Vec2(13.5, -3.5), std::numbers::pi / 4.0}};
  int index = 0;
  for (const auto& wall : walls) {
    const auto path = models::reflect_path(s_i, s_j, wall);
    out.push_back({peer, index++, path->length_m, path->theta_ji_rad, path->theta_ij_rad});
  }
  return out;
}

TEST(MultipathBp, PathSetRecoversTheRelativePositionWithoutNoise) {  // eq. (2)
  const Vec2 s_i(3.0, 7.0);
  const Vec2 s_j(8.0, 3.0);
  const PathSet set = path_set(two_paths(s_i, s_j, 1), 1);
  ASSERT_EQ(set.G.rows(), 2);
  const Vec2 rel = (set.G.transpose() * set.G).inverse() * set.G.transpose() * set.d;
  EXPECT_MATRIX_NEAR(rel, Vec2(s_i - s_j), 1e-10);
}

TEST(MultipathBp, SafeMessageEqualsThePaperForm) {  // §5.2: W⁻¹ = (σ²Σ + P_j)⁻¹, ν = μ_j + G†d
  const PathSet set = path_set(two_paths(Vec2(3.0, 7.0), Vec2(8.0, 3.0), 1), 1);
  MultipathBpParams params;
  params.sigma2 = 2.0;
  Mat2 P_j;
  P_j << 1.5, 0.3, 0.3, 0.8;
  const Vec2 mu_j(8.2, 1.9);
  const auto message = neighbour_message(set, mu_j, P_j.inverse(), false, params);
  ASSERT_TRUE(message.has_value());
  const Mat2 Sigma = (set.G.transpose() * set.G).inverse();
  const Mat2 W_inv = (params.sigma2 * Sigma + P_j).inverse();
  const Vec2 nu = mu_j + Sigma * set.G.transpose() * set.d;
  EXPECT_MATRIX_NEAR(message->information, W_inv, 1e-10);
  EXPECT_MATRIX_NEAR(message->info_vec, Vec2(W_inv * nu), 1e-9);
  // The anchor sends A = GᵀG/σ² (P_0 = 0); a neighbour with Λ = 0 sends nothing.
  const auto anchor = neighbour_message(set, Vec2::Zero(), Mat2::Zero(), true, params);
  ASSERT_TRUE(anchor.has_value());
  EXPECT_MATRIX_NEAR(anchor->information, Mat2(Sigma.inverse() / params.sigma2), 1e-10);
  EXPECT_FALSE(neighbour_message(set, mu_j, Mat2::Zero(), false, params).has_value());
}

TEST(MultipathBp, SinglePathUsesTheGeneralMessage) {  // R = 1: C = σ² + g P_j gᵀ
  auto paths = two_paths(Vec2(3.0, 7.0), Vec2(8.0, 3.0), 1);
  paths.pop_back();
  const PathSet set = path_set(paths, 1);
  MultipathBpParams params;
  params.sigma2 = 2.0;
  const Mat2 P_j = Mat2::Identity();
  const auto message = neighbour_message(set, Vec2(8.0, 3.0), P_j.inverse(), false, params);
  ASSERT_TRUE(message.has_value());
  const Vec2 g = set.G.row(0).transpose();
  EXPECT_MATRIX_NEAR(message->information, Mat2(g * g.transpose() / (params.sigma2 + g.dot(P_j * g))), 1e-12);
  EXPECT_FALSE(pairwise_from_parent(Gaussian2{}, set, params.sigma2).has_value());
}

TEST(MultipathBp, AnchorPublishesInfiniteInformationAndNodeLocalizesFromIt) {
  const Vec2 s_1(4.0, 6.0);
  AgentSetup anchor_setup;
  anchor_setup.anchor = true;
  const MultipathBp anchor(anchor_setup, MultipathBpParams{});
  const Outbox anchor_out = anchor.initial_outbox();
  ASSERT_TRUE(anchor_out.belief.has_value());
  EXPECT_TRUE(anchor_out.belief->infinite_information);

  AgentSetup setup;
  setup.id = 1;
  MultipathBp node(setup, MultipathBpParams{});
  MeasurementBatch batch;
  batch.paths = two_paths(s_1, Vec2::Zero(), 0);
  Inbox inbox;
  inbox.beliefs.push_back({0, 0, *anchor_out.belief});
  const StepOutput out = node.step(StepInput{0, &batch, &inbox});
  EXPECT_TRUE(out.diagnostics.updated);
  EXPECT_TRUE(node.localized());
  EXPECT_MATRIX_NEAR(node.mean(), s_1, 1e-9);
}

}  // namespace
}  // namespace swarmloc::estimators::bp
