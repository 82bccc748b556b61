#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <memory>
#include <numbers>
#include <optional>
#include <random>

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

// docs/algorithms.md §5.2: W⁻¹ = (σ²Σ + P_j)⁻¹, ν = μ_j + G†d.
TEST(MultipathBp, SafeMessageEqualsThePaperForm) {
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
  EXPECT_FALSE(pairwise_from_parent(Gaussian2{}, set, params).has_value());
}

// One reflected path off the horizontal wall y = −1 as seen from s_i, with its angles perturbed.
struct ReflectedPath {
  double length = 0.0;
  double theta_ij = 0.0;  // at S_j
  double theta_ji = 0.0;  // at S_i
};
ReflectedPath reflected(const Vec2& s_i, const Vec2& s_j) {
  const auto path = models::reflect_path(s_i, s_j, models::Wall{Vec2(0.0, -1.0), 0.0});
  return {path->length_m, path->theta_ij_rad, path->theta_ji_rad};
}
PathSet single_path(const ReflectedPath& p) {
  PathSet set;
  set.G = models::path_direction(p.theta_ij, p.theta_ji).transpose();
  set.d = VecX::Constant(1, p.length);
  return set;
}

TEST(MultipathBp, PathVarianceIsTheFirstOrderEffectOfBothAngleErrors) {
  MultipathBpParams params;
  params.sigma2 = 0.01;
  params.doa_variance_rad2 = 1e-4;  // 0.57° std
  // Finite differences of eq. (1)'s prediction g(θ_ij, θ_ji)ᵀ(s_i − s_j) in each angle.
  const auto sensitivity2 = [](const Vec2& s_i, const Vec2& s_j) {
    const ReflectedPath p = reflected(s_i, s_j);
    const Vec2 rel = s_i - s_j;
    constexpr double h = 1e-6;
    const double by_ij = (models::path_direction(p.theta_ij + h, p.theta_ji).dot(rel) -
                          models::path_direction(p.theta_ij - h, p.theta_ji).dot(rel)) /
                         (2 * h);
    const double by_ji = (models::path_direction(p.theta_ij, p.theta_ji + h).dot(rel) -
                          models::path_direction(p.theta_ij, p.theta_ji - h).dot(rel)) /
                         (2 * h);
    return by_ij * by_ij + by_ji * by_ji;
  };
  // Both ends equally far above the wall: the scatter point halves the path, as path_variances assumes.
  const Vec2 s_i(2.0, 5.0);
  const Vec2 s_j(8.0, 5.0);
  const double exact = params.sigma2 + params.doa_variance_rad2 * sensitivity2(s_i, s_j);
  EXPECT_NEAR(path_variances(single_path(reflected(s_i, s_j)), params)(0), exact, 1e-6 * exact);
  // Unequal heights: the equal split under-states the angle term, by less than a factor 2.
  const Vec2 low(2.0, 0.5);
  const Vec2 high(8.0, 9.0);
  const double angle_term = path_variances(single_path(reflected(low, high)), params)(0) - params.sigma2;
  const double true_term = params.doa_variance_rad2 * sensitivity2(low, high);
  EXPECT_LT(angle_term, true_term);
  EXPECT_GT(angle_term, 0.5 * true_term);
  // The same variance from sampled angle errors (uniform, variance σ_θ²) at both ends, 20 000 draws.
  std::mt19937_64 rng(3);
  const double half_width = std::sqrt(3.0 * params.doa_variance_rad2);
  std::uniform_real_distribution<double> angle_error(-half_width, half_width);
  std::normal_distribution<double> length_error(0.0, std::sqrt(params.sigma2));
  const ReflectedPath p = reflected(s_i, s_j);
  double sum = 0.0;
  double squares = 0.0;
  constexpr int kDraws = 20000;
  for (int k = 0; k < kDraws; ++k) {
    const double error_ij = angle_error(rng);  // named draws: argument order is unspecified
    const double error_ji = angle_error(rng);
    const Vec2 g = models::path_direction(p.theta_ij + error_ij, p.theta_ji + error_ji);
    const double residual = p.length + length_error(rng) - g.dot(s_i - s_j);
    sum += residual;
    squares += residual * residual;
  }
  const double sampled = squares / kDraws - (sum / kDraws) * (sum / kDraws);
  EXPECT_NEAR(sampled, exact, 0.05 * exact);
  EXPECT_GT(exact, 3.0 * params.sigma2) << "the angles dominate on this path";
}

TEST(MultipathBp, WithoutAngleErrorsOrOnALineOfSightPathTheVarianceIsSigmaSquared) {
  MultipathBpParams params;
  params.sigma2 = 0.7;
  const PathSet reflections = path_set(two_paths(Vec2(3.0, 7.0), Vec2(8.0, 3.0), 1), 1);
  EXPECT_MATRIX_NEAR(path_variances(reflections, params), VecX::Constant(2, 0.7), 0.0);
  params.doa_variance_rad2 = 1e-4;
  PathSet line_of_sight;
  line_of_sight.G = models::unit_direction(0.3).transpose();
  line_of_sight.d = VecX::Constant(1, 6.0);
  EXPECT_NEAR(path_variances(line_of_sight, params)(0), 0.7, 1e-12);
  // With angle errors each reflected path weighs by its own variance: A = GᵀV⁻¹G from the anchor.
  const VecX v = path_variances(reflections, params);
  EXPECT_GT(v.minCoeff(), 0.7);
  const auto anchor = neighbour_message(reflections, Vec2::Zero(), Mat2::Zero(), true, params);
  ASSERT_TRUE(anchor.has_value());
  const Mat2 expected = reflections.G.transpose() * v.cwiseInverse().asDiagonal() * reflections.G;
  EXPECT_MATRIX_NEAR(anchor->information, expected, 1e-12 * expected.norm());
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

// ---- Exact GaBP (not in Leng et al., the [D-4] ablation) and the centralized baseline ----

// A small network: node 0 the anchor at truth[0], every link seen over the two walls of two_paths() with
// seeded length and angle noise, one path draw shared by both ends (as in Leng et al.'s experiment).
struct SmallNetwork {
  std::vector<Vec2> truth;
  std::vector<std::array<AgentId, 2>> links;
  std::vector<MeasurementBatch> batches;
};
SmallNetwork noisy_network(std::vector<Vec2> truth, std::vector<std::array<AgentId, 2>> links,
                           std::uint64_t seed) {
  SmallNetwork net{std::move(truth), std::move(links), {}};
  net.batches.resize(net.truth.size());
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> length_noise(0.0, 0.5);
  std::normal_distribution<double> angle_noise(0.0, 0.01);
  for (const auto& [i, j] : net.links) {
    const auto at_i = static_cast<std::size_t>(i);
    const auto at_j = static_cast<std::size_t>(j);
    for (auto path : two_paths(net.truth[at_i], net.truth[at_j], j)) {
      const double length_error = length_noise(rng);
      const double here_error = angle_noise(rng);
      const double there_error = angle_noise(rng);
      path.length_m += length_error;
      path.aoa_here_rad += here_error;
      path.aoa_there_rad += there_error;
      net.batches[at_i].paths.push_back(path);
      net.batches[at_j].paths.push_back(
          {i, path.path_index, path.length_m, path.aoa_there_rad, path.aoa_here_rad});
    }
  }
  return net;
}

// Synchronous rounds: every node steps on the beliefs its neighbours published in the previous round.
std::vector<std::unique_ptr<MultipathBp>> run_rounds(const SmallNetwork& net, const MultipathBpParams& params,
                                                     int rounds) {
  std::vector<std::unique_ptr<MultipathBp>> nodes;
  std::vector<BeliefMessage> published;
  for (std::size_t k = 0; k < net.truth.size(); ++k) {
    AgentSetup setup;
    setup.id = static_cast<AgentId>(k);
    setup.anchor = k == 0;
    setup.initial_guess_m = k == 0 ? net.truth[0] : Vec2::Zero();
    nodes.push_back(std::make_unique<MultipathBp>(setup, params));
    published.push_back(*nodes.back()->initial_outbox().belief);
  }
  for (int round = 0; round < rounds; ++round) {
    std::vector<BeliefMessage> next;
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      Inbox inbox;
      for (const auto& [i, j] : net.links) {
        if (i == static_cast<AgentId>(k))
          inbox.beliefs.push_back({j, round - 1, published[static_cast<std::size_t>(j)]});
        if (j == static_cast<AgentId>(k))
          inbox.beliefs.push_back({i, round - 1, published[static_cast<std::size_t>(i)]});
      }
      const auto out = nodes[k]->step(StepInput{round, round == 0 ? &net.batches[k] : nullptr, &inbox});
      next.push_back(*out.outbox.belief);
    }
    published = std::move(next);
  }
  return nodes;
}

std::vector<Gaussian2> centralized(const SmallNetwork& net, const MultipathBpParams& params) {
  std::vector<std::optional<Vec2>> anchors(net.truth.size());
  anchors[0] = net.truth[0];
  std::vector<LinkPaths> links;
  for (const auto& [i, j] : net.links) {
    links.push_back({i, j, path_set(net.batches[static_cast<std::size_t>(i)].paths, j)});
  }
  const auto solution = centralized_from_paths(anchors, links, params);
  EXPECT_TRUE(solution.has_value());
  return solution.value_or(std::vector<Gaussian2>(net.truth.size()));
}

TEST(CentralizedFromPaths, NoiseFreePathsGiveTheTruthAndAnUnlinkedNodeNoSolution) {
  // (8.5, 2) rather than (8, 2): a pair perpendicular to the 45° wall sees parallel rays (‖g‖ → ∞).
  const std::vector<Vec2> truth{Vec2::Zero(), Vec2(4.0, 6.0), Vec2(8.5, 2.0), Vec2(7.0, 9.0)};
  std::vector<std::optional<Vec2>> anchors(4);
  anchors[0] = truth[0];
  std::vector<LinkPaths> links;
  for (const auto& [i, j] : std::vector<std::array<AgentId, 2>>{{1, 0}, {2, 1}, {3, 2}, {3, 1}}) {
    links.push_back(
        {i, j,
         path_set(two_paths(truth[static_cast<std::size_t>(i)], truth[static_cast<std::size_t>(j)], j), j)});
  }
  const auto solution = centralized_from_paths(anchors, links, MultipathBpParams{});
  ASSERT_TRUE(solution.has_value());
  for (std::size_t k = 0; k < truth.size(); ++k) EXPECT_MATRIX_NEAR((*solution)[k].mean, truth[k], 1e-9) << k;
  EXPECT_MATRIX_NEAR((*solution)[0].covariance, Mat2::Zero(), 0.0);
  links.pop_back();
  links.pop_back();  // node 3 now has no link
  EXPECT_FALSE(centralized_from_paths(anchors, links, MultipathBpParams{}).has_value());
  links.push_back({3, 3, PathSet{}});
  EXPECT_THROW((void)centralized_from_paths(anchors, links, MultipathBpParams{}), std::invalid_argument);
}

// On a tree, Gaussian BP with cavity messages is exact: its means and covariances are the centralized
// least-squares solution's once messages have crossed the tree. Leng et al.'s beliefs count every edge's
// evidence again on the way back, so they are more confident than the data allow.
TEST(MultipathBp, ExactMessagesOnATreeGiveTheCentralizedMeansAndCovariances) {
  const auto net =
      noisy_network({Vec2::Zero(), Vec2(4.0, 6.0), Vec2(8.5, 2.0), Vec2(7.0, 9.0), Vec2(1.0, 9.5)},
                    {{1, 0}, {2, 1}, {3, 1}, {4, 3}}, 3);
  MultipathBpParams params;
  params.sigma2 = 0.25;
  const auto reference = centralized(net, params);
  params.exact_messages = true;
  const auto exact = run_rounds(net, params, 8);
  params.exact_messages = false;
  const auto printed = run_rounds(net, params, 8);
  for (std::size_t k = 1; k < net.truth.size(); ++k) {
    EXPECT_MATRIX_NEAR(exact[k]->mean(), reference[k].mean, 1e-9) << k;
    EXPECT_MATRIX_NEAR(Mat2(exact[k]->information().inverse()), reference[k].covariance, 1e-9) << k;
  }
  // Node 4, three hops out: Leng et al.'s belief claims more than twice the information the data hold.
  EXPECT_GT(printed[4]->information().trace(), 2.0 * reference[4].covariance.inverse().trace());
  // A node publishes the messages it summed. Without priors only what comes from the anchor's side
  // carries information: node 3's leaf (node 4) has nothing to tell it but what node 3 told it.
  const BeliefMessage published = *exact[3]->initial_outbox().belief;
  ASSERT_EQ(published.contributions.size(), 1u);
  EXPECT_EQ(published.contributions[0].from, 1);
  EXPECT_MATRIX_NEAR(published.contributions[0].information, exact[3]->information(), 0.0);
}

// On Leng et al.'s five-node loop the means still converge to the centralized solution (Gaussian BP's fixed
// point).
TEST(MultipathBp, ExactMessagesOnTheLoopOfTheExperimentConvergeToTheCentralizedMeans) {
  const auto net =
      noisy_network({Vec2::Zero(), Vec2(3.0, 8.0), Vec2(9.0, 1.0), Vec2(6.0, 9.0), Vec2(9.5, 4.0)},
                    {{1, 0}, {2, 0}, {3, 1}, {4, 2}, {3, 4}}, 5);
  MultipathBpParams params;
  params.sigma2 = 0.25;
  const auto reference = centralized(net, params);
  params.exact_messages = true;
  const auto exact = run_rounds(net, params, 200);
  double printed_gap = 0.0;
  params.exact_messages = false;
  const auto printed = run_rounds(net, params, 200);
  for (std::size_t k = 1; k < net.truth.size(); ++k) {
    EXPECT_MATRIX_NEAR(exact[k]->mean(), reference[k].mean, 1e-8) << k;
    printed_gap = std::max(printed_gap, (printed[k]->mean() - reference[k].mean).norm());
  }
  EXPECT_GT(printed_gap, 1e-4);  // Leng et al.'s fixed point is another one: the test tells the two apart
}

}  // namespace
}  // namespace swarmloc::estimators::bp
