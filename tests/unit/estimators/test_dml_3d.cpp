// dml in three dimensions (docs/algorithms.md §9.9) against a 3-D batch maximum-likelihood solve of the same
// draws: the fixed point and its covariance, multilateration on four references, the mirror pair three
// leave, a local map in 3-D, and the altitude at the message boundary.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <set>
#include <tuple>
#include <utility>
#include <vector>

#include "dense_range_ml.hpp"
#include "swarmloc/estimators/builders.hpp"
#include "swarmloc/estimators/dml/dml.hpp"
#include "swarmloc/estimators/dml/local_map.hpp"
#include "swarmloc/estimators/self_check.hpp"

namespace swarmloc::estimators {
namespace {

constexpr double kRange3dStdM = 0.1;
constexpr double kNoInformation = std::numeric_limits<double>::infinity();

struct Net3d {
  std::vector<Vec3> truth;
  std::vector<bool> anchor;
  std::vector<std::pair<int, int>> edges;  // each measured at both ends, every data step
};

struct Draws3d {
  std::vector<std::tuple<int, int, double>> draws;  // (measuring agent, peer, range)
};

Vec3 position_of(const Estimate& estimate) { return join(estimate.mean_m, estimate.altitude->z_m); }
Mat3 covariance_of(const Estimate& estimate) { return join(estimate.covariance, *estimate.altitude); }

/// Drives one DmlT<3> per agent in synchronous rounds, as test_dml.cpp does in 2-D: data steps feed fresh
/// ranges (noise_std_m 0: exact ones), quiet steps only exchange states.
class Rounds3d {
 public:
  Rounds3d(const Net3d& net, const std::vector<Vec3>& guesses, double guess_std_m,
           double radius_m = kNoInformation)
      : net_(net) {
    for (std::size_t i = 0; i < net.truth.size(); ++i) {
      AgentSetup setup;
      setup.id = static_cast<AgentId>(i);
      setup.anchor = net.anchor[i];
      setup.dimensions = 3;
      const Vec3 guess = net.anchor[i] ? net.truth[i] : guesses[i];
      setup.initial_guess_m = guess.head<2>();
      setup.initial_altitude_m = guess.z();
      setup.initial_guess_std_m = guess_std_m;
      setup.comm_radius_m = radius_m;
      agents_.push_back(std::make_unique<DmlT<3>>(setup, KalmanFilterParams{}));
      outboxes_.push_back(agents_.back()->initial_outbox());
    }
  }

  void run(int data_steps, int quiet_steps, std::mt19937_64& rng, Draws3d& log,
           double noise_std_m = kRange3dStdM) {
    for (int k = 0; k < data_steps + quiet_steps; ++k) step(k < data_steps, rng, log, noise_std_m);
  }

  [[nodiscard]] Estimate estimate(int i) const { return agents_[static_cast<std::size_t>(i)]->estimate(); }
  [[nodiscard]] const StateMessage& published(int i) const {
    return *outboxes_[static_cast<std::size_t>(i)].state;
  }
  /// Drops the altitude from every state agent i receives (a planar sender).
  void strip_altitudes_to(int i) { stripped_ = i; }
  Net3d& network() { return net_; }

 private:
  void step(bool with_data, std::mt19937_64& rng, Draws3d& log, double noise_std_m) {
    std::normal_distribution<double> noise(0.0, 1.0);
    std::vector<Outbox> next(agents_.size());
    for (std::size_t i = 0; i < agents_.size(); ++i) {
      MeasurementBatch batch;
      Inbox inbox;
      for (const auto& [a, b] : net_.edges) {
        if (a != static_cast<int>(i) && b != static_cast<int>(i)) continue;
        const int peer = a == static_cast<int>(i) ? b : a;
        const auto p = static_cast<std::size_t>(peer);
        if (with_data) {
          const double range = (net_.truth[i] - net_.truth[p]).norm() + noise_std_m * noise(rng);
          batch.ranges.push_back({peer, range, kRange3dStdM});
          log.draws.emplace_back(static_cast<int>(i), peer, range);
        }
        StateMessage state = *outboxes_[p].state;
        if (stripped_ == static_cast<int>(i)) state.altitude.reset();
        inbox.states.push_back({peer, 0, state});
      }
      batch.world_step = with_data ? 0 : -1;
      StepInput input;
      input.measurements = with_data ? &batch : nullptr;
      input.inbox = &inbox;
      next[i] = agents_[i]->step(input).outbox;
    }
    outboxes_ = std::move(next);
  }

  Net3d net_;
  int stripped_ = -1;
  std::vector<std::unique_ptr<Estimator>> agents_;
  std::vector<Outbox> outboxes_;
};

/// Dense Gauss–Newton on Σ (r − ‖x_i − x_j‖)²/σ² over every draw, anchors fixed, from the truth: the 3-D
/// batch ML and its Fisher information (unknowns' coordinates in agent order).
std::pair<std::vector<Vec3>, MatX> ml_3d(const Net3d& net, const Draws3d& log) {
  return testing::dense_range_ml<3>(net.truth, net.anchor, log.draws, kRange3dStdM);
}

/// 24 agents in a 30 × 30 × 10 m box, 6 of them anchors at several heights, linked within the radius that
/// gives a mean degree of 9 (a disk graph).
std::pair<Net3d, double> random_network_3d(unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> across(0.0, 30.0);
  std::uniform_real_distribution<double> up(0.0, 10.0);
  Net3d net;
  constexpr int kAgents = 24;
  for (int i = 0; i < kAgents; ++i) {
    const double x = across(rng);  // one draw per statement: argument order is unspecified
    const double y = across(rng);
    const double z = up(rng);
    net.truth.emplace_back(x, y, z);
    net.anchor.push_back(i % 4 == 0);
  }
  std::vector<double> distances;
  for (int i = 0; i < kAgents; ++i)
    for (int j = i + 1; j < kAgents; ++j)
      distances.push_back(
          (net.truth[static_cast<std::size_t>(i)] - net.truth[static_cast<std::size_t>(j)]).norm());
  std::sort(distances.begin(), distances.end());
  const double radius = distances[9 * kAgents / 2];  // 9·N/2 links: mean degree 9
  for (int i = 0; i < kAgents; ++i)
    for (int j = i + 1; j < kAgents; ++j)
      if ((net.truth[static_cast<std::size_t>(i)] - net.truth[static_cast<std::size_t>(j)]).norm() < radius)
        net.edges.emplace_back(i, j);
  return {net, radius};
}

int unknown_index_3d(const Net3d& net, int agent) {
  int index = 0;
  for (int i = 0; i < agent; ++i) index += net.anchor[static_cast<std::size_t>(i)] ? 0 : 1;
  return index;
}

TEST(Dml3d, ReachesTheBatchMaximumLikelihoodOfEveryDrawInABox) {
  const auto [net, radius] = random_network_3d(21);
  // Every agent starts at the same point, with nothing known about it: the anchors and the graph place them.
  const std::vector<Vec3> guesses(net.truth.size(), Vec3(15.0, 15.0, 5.0));
  Rounds3d rounds(net, guesses, kNoInformation, radius);
  std::mt19937_64 rng(22);
  Draws3d log;
  rounds.run(100, 200, rng, log);
  const auto [ml, fisher] = ml_3d(net, log);
  const MatX exact = fisher.inverse();
  double trace_ratio_sum = 0.0;
  int unknowns = 0;
  for (int i = 0; i < static_cast<int>(net.truth.size()); ++i) {
    if (net.anchor[static_cast<std::size_t>(i)]) continue;
    const Estimate estimate = rounds.estimate(i);
    ASSERT_TRUE(estimate.valid) << i;
    ASSERT_TRUE(estimate.altitude.has_value()) << i;
    EXPECT_FALSE(estimate.inconsistent) << i;
    // Not to the last digits: where a belief is almost all one neighbour's message no cavity goes back to it,
    // and that edge's messages miss the ML's fixed point slightly (docs/algorithms.md §9.2; 0.59 mm here).
    EXPECT_LT((position_of(estimate) - ml[static_cast<std::size_t>(i)]).norm(), 1e-3) << "agent " << i;
    const Mat3 p = covariance_of(estimate);
    EXPECT_LT((p - p.transpose()).norm(), 1e-12 * p.norm()) << i;
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<Mat3>(p).eigenvalues().minCoeff(), 0.0) << i;
    const int k = unknown_index_3d(net, i);
    const Mat3 expected = exact.block<3, 3>(3 * k, 3 * k);
    const double ratio = p.trace() / expected.trace();
    // Loops beyond a neighbourhood are counted again: a little overconfident, never far off.
    EXPECT_GT(ratio, 0.65) << "agent " << i;
    EXPECT_LT(ratio, 1.15) << "agent " << i;
    trace_ratio_sum += ratio;
    ++unknowns;
  }
  EXPECT_GT(trace_ratio_sum / unknowns, 0.85);
  EXPECT_LT(trace_ratio_sum / unknowns, 1.05);
}

TEST(Dml3d, CovarianceIsTheExactMarginalOnATree) {
  // Unknowns 4 and 5 share one edge; each also ranges to four anchors at different heights: a tree between
  // the unknowns, where belief propagation is exact.
  Net3d net;
  net.truth = {{0, 0, 0}, {20, 0, 6},  {0, 20, 9},   {20, 20, 2},
               {7, 8, 3}, {14, 11, 6}, {30, 10, 10}, {25, 25, 0}};
  net.anchor = {true, true, true, true, false, false, true, true};
  net.edges = {{0, 4}, {1, 4}, {2, 4}, {3, 4}, {4, 5}, {1, 5}, {3, 5}, {6, 5}, {7, 5}};
  std::vector<Vec3> guesses = net.truth;
  for (auto& g : guesses) g += Vec3(0.7, -0.4, 0.3);
  Rounds3d rounds(net, guesses, 0.5);
  std::mt19937_64 rng(23);
  Draws3d log;
  rounds.run(30, 60, rng, log);
  const auto [ml, fisher] = ml_3d(net, log);
  const MatX exact = fisher.inverse();
  for (int i = 4; i < 6; ++i) {
    EXPECT_LT((position_of(rounds.estimate(i)) - ml[static_cast<std::size_t>(i)]).norm(), 1e-6) << i;
    const Mat3 expected = exact.block<3, 3>(3 * (i - 4), 3 * (i - 4));
    const Mat3 got = covariance_of(rounds.estimate(i));
    EXPECT_LT((got - expected).norm(), 1e-6 * expected.norm()) << "agent " << i << "\n"
                                                               << got << "\n"
                                                               << expected;
  }
}

/// Four anchors (three in a tilted plane, one off it) and one agent to place.
Net3d four_references() {
  Net3d net;
  net.truth = {{0, 0, 1}, {20, 0, 3}, {5, 18, 8}, {12, 6, 15}, {9, 7, -4}};
  net.anchor = {true, true, true, true, false};
  net.edges = {{0, 4}, {1, 4}, {2, 4}, {3, 4}};
  return net;
}

/// `x` reflected across the plane through a, b, c.
Vec3 reflected_3d(const Vec3& x, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 n = (b - a).cross(c - a).normalized();
  return x - 2.0 * (x - a).dot(n) * n;
}

TEST(Dml3d, MultilateratesExactlyFromFourReferencesOnceSureEnough) {
  // One draw per range leaves the linear solution's spread above 2 % of the shortest range (the 3-D bound,
  // docs/algorithms.md §9.9; the planar 10 % would start it): the agent waits for more draws.
  const Net3d net = four_references();
  Rounds3d rounds(net, std::vector<Vec3>(5, Vec3(40, -30, 20)), kNoInformation);
  std::mt19937_64 rng(24);
  Draws3d log;
  rounds.run(1, 0, rng, log, 0.0);
  EXPECT_FALSE(rounds.estimate(4).valid);
  int steps = 1;
  for (; steps < 50 && !rounds.estimate(4).valid; ++steps) rounds.run(1, 0, rng, log, 0.0);
  EXPECT_LT(steps, 50);
  const Estimate estimate = rounds.estimate(4);
  ASSERT_TRUE(estimate.valid);
  EXPECT_LT((position_of(estimate) - net.truth[4]).norm(), 1e-9);
  // Published: planar mean and covariance, the altitude beside them.
  const StateMessage& state = rounds.published(4);
  ASSERT_TRUE(state.altitude.has_value());
  EXPECT_LT((join(state.mean_m, state.altitude->z_m) - net.truth[4]).norm(), 1e-9);
  EXPECT_GT(state.altitude->variance_m2, 0.0);
  EXPECT_LT(state.altitude->variance_m2, 1.0);
}

TEST(Dml3d, ThreeReferencesLeaveAMirrorPairAcrossTheirPlaneTheGuessPicksFrom) {
  Net3d net = four_references();
  net.edges.pop_back();  // the agent hears anchors 0–2 only
  const Vec3 mirror = reflected_3d(net.truth[4], net.truth[0], net.truth[1], net.truth[2]);
  ASSERT_GT((mirror - net.truth[4]).norm(), 5.0);
  const int steps = static_cast<int>(DmlT<3>::kInitializationPatienceSteps) + 5;
  for (const auto& [guess, expected] : {std::pair{net.truth[4], net.truth[4]}, std::pair{mirror, mirror}}) {
    std::vector<Vec3> guesses(5, guess + Vec3(0.3, -0.2, 0.1));
    Rounds3d rounds(net, guesses, 0.2);
    std::mt19937_64 rng(25);
    Draws3d log;
    rounds.run(steps, 0, rng, log, 0.0);
    const Estimate estimate = rounds.estimate(4);
    ASSERT_TRUE(estimate.valid);
    EXPECT_LT((position_of(estimate) - expected).norm(), 1e-6);
    EXPECT_FALSE(estimate.inconsistent);  // the guess told the pair apart
  }
}

TEST(Dml3d, TheGraphPicksTheMirrorMemberAndLaterMovesAnAgentOffAWrongOne) {
  // Anchor 5 lies 3 m beyond the mirror image of agent 4 (across the plane of anchors 0–2), within the radius
  // of it, but agent 4 does not hear it: the mirror image is impossible.
  Net3d net = four_references();
  net.edges.pop_back();
  const double radius = 17.0;
  const Vec3 mirror = reflected_3d(net.truth[4], net.truth[0], net.truth[1], net.truth[2]);
  net.truth.push_back(mirror + 3.0 * (mirror - net.truth[4]).normalized());
  net.anchor.push_back(true);
  ASSERT_GT((net.truth[5] - net.truth[4]).norm(), radius);
  ASSERT_LT((net.truth[5] - net.truth[0]).norm(), radius);
  const int steps = 3 * static_cast<int>(DmlT<3>::kInitializationPatienceSteps) + 5;
  const std::vector<Vec3> at_the_mirror(6, mirror);
  {
    // The graph is known before the start: it picks the true member, whatever the guess.
    Net3d heard = net;
    heard.edges.emplace_back(0, 5);
    Rounds3d rounds(heard, at_the_mirror, kNoInformation, radius);
    std::mt19937_64 rng(26);
    Draws3d log;
    rounds.run(steps, 0, rng, log, 0.0);
    EXPECT_LT((position_of(rounds.estimate(4)) - net.truth[4]).norm(), 1e-6);
    EXPECT_FALSE(rounds.estimate(4).inconsistent);
  }
  {
    // Nothing tells the pair apart: the agent starts at the member nearer its guess (the wrong one),
    // flagged. Then anchor 0 starts ranging to anchor 5 and relays its position: the agent moves across
    // the plane of the three references it started from.
    Rounds3d rounds(net, at_the_mirror, kNoInformation, radius);
    std::mt19937_64 rng(27);
    Draws3d log;
    rounds.run(steps, 0, rng, log, 0.0);
    EXPECT_LT((position_of(rounds.estimate(4)) - mirror).norm(), 1e-6);
    EXPECT_TRUE(rounds.estimate(4).inconsistent);
    rounds.network().edges.emplace_back(0, 5);
    rounds.run(10, 0, rng, log, 0.0);
    EXPECT_LT((position_of(rounds.estimate(4)) - net.truth[4]).norm(), 1e-6);
    EXPECT_FALSE(rounds.estimate(4).inconsistent);
  }
}

TEST(Dml3d, AStateWithoutAltitudeIsNotUsable) {
  const Net3d net = four_references();
  Rounds3d rounds(net, std::vector<Vec3>(5, Vec3(40, -30, 20)), kNoInformation);
  rounds.strip_altitudes_to(4);
  std::mt19937_64 rng(28);
  Draws3d log;
  rounds.run(3 * static_cast<int>(DmlT<3>::kInitializationPatienceSteps) + 5, 0, rng, log, 0.0);
  EXPECT_FALSE(rounds.estimate(4).valid);
}

/// Pocket: agents 0–2 to place, each ranging to three of six anchors at several heights and to each other.
/// No one of them has D + 1 = 4 localized neighbours; the three together are rigid.
struct Pocket3d {
  std::vector<Vec3> truth{{8, 6, 3},    {15, 9, 6}, {10, 14, 2}, {0, 0, 0}, {22, 2, 8},
                          {18, 20, 10}, {2, 18, 5}, {12, 8, 12}, {9, 2, 9}};
  std::vector<std::pair<int, int>> links{{0, 3}, {0, 7}, {0, 8}, {1, 4}, {1, 5}, {1, 7},
                                         {2, 5}, {2, 6}, {2, 3}, {0, 1}, {1, 2}, {0, 2}};
};

TEST(Dml3d, APocketNoAgentOfWhichHearsFourAnchorsPlacesItselfFromItsLocalMap) {
  const Pocket3d pocket;
  Net3d net;
  net.truth = pocket.truth;
  net.edges = pocket.links;
  for (std::size_t i = 0; i < net.truth.size(); ++i) net.anchor.push_back(i >= 3);
  // Far off guesses, all the same, nothing known about them.
  Rounds3d rounds(net, std::vector<Vec3>(net.truth.size(), Vec3(60, -40, 30)), kNoInformation);
  std::mt19937_64 rng(29);
  Draws3d log;
  rounds.run(static_cast<int>(DmlT<3>::kInitializationPatienceSteps) + 10, 40, rng, log);
  const auto ml = ml_3d(net, log).first;
  for (int i = 0; i < 3; ++i) {
    const Estimate estimate = rounds.estimate(i);
    ASSERT_TRUE(estimate.valid) << i;
    EXPECT_LT((position_of(estimate) - ml[static_cast<std::size_t>(i)]).norm(), 1e-4) << i;
    EXPECT_FALSE(estimate.inconsistent) << i;
  }
}

TEST(Dml3dLocalMap, ThreeKnownNodesLeaveAMirrorImageAcrossTheirPlaneFourFixTheMap) {
  const Pocket3d pocket;
  const auto nodes_with_known = [&](const std::set<int>& known) {
    std::vector<local_map::NodeT<3>> nodes;
    for (std::size_t i = 0; i < pocket.truth.size(); ++i) {
      const bool is_known = known.contains(static_cast<int>(i));
      nodes.push_back({is_known, is_known ? pocket.truth[i] : Vec3(40, -30, 20)});
    }
    return nodes;
  };
  std::vector<local_map::Range> ranges;
  for (const auto& [a, b] : pocket.links)
    ranges.push_back(
        {a, b, (pocket.truth[static_cast<std::size_t>(a)] - pocket.truth[static_cast<std::size_t>(b)]).norm(),
         100.0});
  // Anchors 4, 5 and 7 only (agents 0–2 range to no other anchor here): a mirror image across their plane.
  std::vector<local_map::Range> to_three;
  for (const auto& range : ranges) {
    if (range.first != 3 && range.second != 3 && range.first != 6 && range.second != 6 && range.first != 8 &&
        range.second != 8)
      to_three.push_back(range);
  }
  // Agent 0 keeps ranges to 1, 2 and 7 only: three plus the two to place; add two more so each to place
  // has 4.
  to_three.push_back({0, 4, (pocket.truth[0] - pocket.truth[4]).norm(), 100.0});
  to_three.push_back({2, 4, (pocket.truth[2] - pocket.truth[4]).norm(), 100.0});
  const auto mirrored = local_map::place<3>(nodes_with_known({4, 5, 7}), to_three, 1e-3, 1.0);
  ASSERT_TRUE(mirrored.has_value());
  ASSERT_TRUE(mirrored->alternative_m.has_value());
  const Vec3 image = reflected_3d(pocket.truth[0], pocket.truth[4], pocket.truth[5], pocket.truth[7]);
  const bool true_first = (mirrored->position_m - pocket.truth[0]).norm() < 1e-6;
  EXPECT_LT(((true_first ? *mirrored->alternative_m : mirrored->position_m) - image).norm(), 1e-6);
  EXPECT_LT(((true_first ? mirrored->position_m : *mirrored->alternative_m) - pocket.truth[0]).norm(), 1e-6);
  // All six anchors, not coplanar: one map.
  const auto fixed = local_map::place<3>(nodes_with_known({3, 4, 5, 6, 7, 8}), ranges, 1e-3, 1.0);
  ASSERT_TRUE(fixed.has_value());
  EXPECT_FALSE(fixed->alternative_m.has_value());
  EXPECT_LT((fixed->position_m - pocket.truth[0]).norm(), 1e-6);
}

TEST(Dml3d, AGuessFarFromBothMirrorMembersPicksNeither) {
  // Three references leave a mirror pair far apart for the guess's std (6σ), but the guess lies 20 m from
  // both: it allows neither (a reference would be off), so the agent waits, and after the patience starts
  // ambiguous (flagged). Before (docs/algorithms.md §9.9) it started at the nearer member, unflagged.
  Net3d net = four_references();
  net.edges.pop_back();
  const Vec3 mirror = reflected_3d(net.truth[4], net.truth[0], net.truth[1], net.truth[2]);
  const double guess_std_m = 0.5;
  ASSERT_GT((mirror - net.truth[4]).norm(), 6.0 * guess_std_m);
  const Vec3 along_plane = (net.truth[1] - net.truth[0]).normalized();
  const std::vector<Vec3> guesses(5, net.truth[4] + 20.0 * along_plane);
  Rounds3d rounds(net, guesses, guess_std_m);
  std::mt19937_64 rng(31);
  Draws3d log;
  rounds.run(static_cast<int>(DmlT<3>::kInitializationPatienceSteps) + 5, 0, rng, log, 0.0);
  EXPECT_FALSE(rounds.estimate(4).valid);
  rounds.run(2 * static_cast<int>(DmlT<3>::kInitializationPatienceSteps), 0, rng, log, 0.0);
  const Estimate estimate = rounds.estimate(4);
  ASSERT_TRUE(estimate.valid);
  EXPECT_TRUE(estimate.inconsistent);
  const double to_truth = (position_of(estimate) - net.truth[4]).norm();
  const double to_mirror = (position_of(estimate) - mirror).norm();
  EXPECT_LT(std::min(to_truth, to_mirror), 1e-6);
}

TEST(Dml3dLocalMap, AMirrorImageWithinTheGapOfTheBestIsAnAlternative) {
  // Three known nodes in a plane and a fourth known one held at the mirror image of where it is (held nodes
  // can be off by more than their covariance): the mirror image of node 0 fits all four ranges exactly, the
  // true place fails the χ² test at 10⁻³ but lies within the gap χ²₁(10⁻⁶) of the best fit.
  const Vec3 a(0, 0, 0), b(20, 0, 2), c(3, 18, 1), truth(9, 7, 6);
  const Vec3 normal = (b - a).cross(c - a).normalized();
  const Vec3 on_plane = Vec3(16, 14, 0) - (Vec3(16, 14, 0) - a).dot(normal) * normal;
  const Vec3 e = on_plane + 0.8 * normal;
  const Vec3 e_held = on_plane - 0.8 * normal;
  const std::vector<local_map::NodeT<3>> nodes = {
      {false, truth + Vec3(0.3, -0.2, 0.1)}, {true, a}, {true, b}, {true, c}, {true, e_held}};
  std::vector<local_map::Range> ranges;
  for (int k = 1; k <= 4; ++k)
    ranges.push_back(
        {0, k, (truth - std::vector<Vec3>{a, b, c, e}[static_cast<std::size_t>(k - 1)]).norm(), 100.0});
  const Vec3 image = reflected_3d(truth, a, b, c);
  const auto alone = local_map::place<3>(nodes, ranges, 1e-3, 1.0);
  ASSERT_TRUE(alone.has_value());
  EXPECT_LT((alone->position_m - image).norm(), 1e-6);
  EXPECT_FALSE(alone->alternative_m.has_value());  // the wrong place, decided
  const double gap = chi_square_upper_quantile(1.0, 1e-6);
  const auto seen = local_map::place<3>(nodes, ranges, 1e-3, 1.0, {}, gap);
  ASSERT_TRUE(seen.has_value());
  EXPECT_LT((seen->position_m - image).norm(), 1e-6);
  ASSERT_TRUE(seen->alternative_m.has_value());
  EXPECT_LT((*seen->alternative_m - truth).norm(), 1.0);
}

TEST(Dml3d, BuildersPickTheDimensionAndDmlTrackStaysPlanar) {
  AgentSetup setup;
  setup.initial_altitude_m = 4.0;
  setup.dimensions = 3;
  const auto three = builders::dml(setup, EstimatorParams{});
  ASSERT_TRUE(three->initial_outbox().state->altitude.has_value());
  EXPECT_EQ(three->initial_outbox().state->altitude->z_m, 4.0);
  EXPECT_EQ(three->initial_outbox().state->altitude->variance_m2, kUndefinedVarianceM2);
  EXPECT_THROW((void)builders::dml_track(setup, EstimatorParams{}), std::invalid_argument);
  setup.dimensions = 2;
  EXPECT_FALSE(builders::dml(setup, EstimatorParams{})->initial_outbox().state->altitude.has_value());
  setup.dimensions = 4;
  EXPECT_THROW((void)builders::dml(setup, EstimatorParams{}), std::invalid_argument);
}

}  // namespace
}  // namespace swarmloc::estimators
