// dml (docs/algorithms.md §9) against a batch maximum-likelihood solve of the same draws: the fixed point,
// its covariance on a tree (where belief propagation is exact), the start from any guess and the
// self-checks.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <tuple>
#include <utility>
#include <vector>

#include "dense_range_ml.hpp"
#include "swarmloc/estimators/dml/dml.hpp"
#include "swarmloc/estimators/dml/region.hpp"

namespace swarmloc::estimators {
namespace {

constexpr double kRangeStdM = 0.1;

struct DmlNetwork {
  std::vector<Vec2> truth;
  std::vector<bool> anchor;
  std::vector<std::pair<int, int>> edges;  // each measured at both ends, every data step
};

/// Every draw of every step, by (measuring agent, peer): what the batch solve uses.
struct DrawLog {
  std::vector<std::tuple<int, int, double>> draws;
};

/// Drives one Dml per agent in synchronous rounds: data steps feed fresh ranges, quiet steps only
/// exchange states so the summaries and the solve settle on the same data.
class DmlRounds {
 public:
  DmlRounds(const DmlNetwork& net, const std::vector<Vec2>& guesses, double guess_std_m,
            double radius_m = std::numeric_limits<double>::infinity())
      : net_(net) {
    for (std::size_t i = 0; i < net.truth.size(); ++i) {
      AgentSetup setup;
      setup.id = static_cast<AgentId>(i);
      setup.anchor = net.anchor[i];
      setup.initial_guess_m = net.anchor[i] ? net.truth[i] : guesses[i];
      setup.initial_guess_std_m = guess_std_m;
      setup.comm_radius_m = radius_m;
      agents_.push_back(std::make_unique<Dml>(setup, KalmanFilterParams{}));
      outboxes_.push_back(agents_.back()->initial_outbox());
    }
  }

  void run(int data_steps, int quiet_steps, std::mt19937_64& rng, DrawLog& log, double bias_m = 0.0) {
    for (int k = 0; k < data_steps + quiet_steps; ++k) step(k < data_steps, rng, log, bias_m);
  }

  [[nodiscard]] Estimate estimate(int i) const { return agents_[static_cast<std::size_t>(i)]->estimate(); }
  /// The belief propagation covariance agent i last published to its neighbours.
  [[nodiscard]] Mat2 published_covariance(int i) const {
    return outboxes_[static_cast<std::size_t>(i)].state->covariance;
  }

  /// Every data step repeats the first step's draws (a sensor that returns one value, noise.draw: once).
  void repeat_first_draws() { repeat_ = true; }

 private:
  void step(bool with_data, std::mt19937_64& rng, DrawLog& log, double bias_m) {
    std::normal_distribution<double> noise(0.0, kRangeStdM);
    std::vector<Outbox> next(agents_.size());
    for (std::size_t i = 0; i < agents_.size(); ++i) {
      MeasurementBatch batch;
      Inbox inbox;
      for (const auto& [a, b] : net_.edges) {
        if (a != static_cast<int>(i) && b != static_cast<int>(i)) continue;
        const int peer = a == static_cast<int>(i) ? b : a;
        const auto p = static_cast<std::size_t>(peer);
        if (with_data) {
          // The bias, if any, sits on agent 0's ranges to its first edge's peer (a broken sensor).
          const double bias = (i == 0 && peer == net_.edges.front().second) ? bias_m : 0.0;
          const auto key = std::pair{static_cast<int>(i), peer};
          const double range = repeat_ && first_draws_.contains(key)
                                   ? first_draws_.at(key)
                                   : (net_.truth[i] - net_.truth[p]).norm() + noise(rng) + bias;
          first_draws_.emplace(key, range);
          batch.ranges.push_back({peer, range, kRangeStdM});
          log.draws.emplace_back(static_cast<int>(i), peer, range);
        }
        inbox.states.push_back({peer, 0, *outboxes_[p].state});
      }
      batch.world_step = with_data ? 0 : -1;
      StepInput input;
      input.measurements = with_data ? &batch : nullptr;
      input.inbox = &inbox;
      next[i] = agents_[i]->step(input).outbox;
    }
    outboxes_ = std::move(next);
  }

  const DmlNetwork& net_;
  bool repeat_ = false;
  std::map<std::pair<int, int>, double> first_draws_;
  std::vector<std::unique_ptr<Dml>> agents_;
  std::vector<Outbox> outboxes_;
};

/// Gauss–Newton on Σ (r − ‖x_i − x_j‖)²/σ² over every draw, anchors fixed, from the truth. Returns the
/// solution and the Fisher information at it (unknowns' coordinates in agent order).
std::pair<std::vector<Vec2>, MatX> batch_ml(const DmlNetwork& net, const DrawLog& log) {
  return testing::dense_range_ml<2>(net.truth, net.anchor, log.draws, kRangeStdM);
}

DmlNetwork loopy_network() {
  DmlNetwork net;
  net.truth = {{0, 0}, {20, 0}, {0, 20}, {20, 20}, {6, 8}, {14, 9}, {9, 15}};
  net.anchor = {true, true, true, true, false, false, false};
  for (int i = 0; i < 7; ++i)
    for (int j = i + 1; j < 7; ++j)
      if ((!net.anchor[static_cast<std::size_t>(i)] || !net.anchor[static_cast<std::size_t>(j)]) &&
          (net.truth[static_cast<std::size_t>(i)] - net.truth[static_cast<std::size_t>(j)]).norm() < 23.0)
        net.edges.emplace_back(i, j);
  return net;
}

std::vector<Vec2> guesses_near_truth(const DmlNetwork& net) {
  std::vector<Vec2> guesses = net.truth;
  for (auto& g : guesses) g += Vec2(0.7, -0.4);
  return guesses;
}

/// Runs `rounds` on `net` (40 data steps, then 80 quiet ones) and returns the inverse Fisher information of
/// the batch solution of those draws: the exact marginal covariances, unknowns in agent order.
MatX exact_covariance_after_run(DmlRounds& rounds, const DmlNetwork& net, unsigned seed) {
  std::mt19937_64 rng(seed);
  DrawLog log;
  rounds.run(40, 80, rng, log);
  return batch_ml(net, log).second.inverse();
}

TEST(Dml, ReachesTheBatchMaximumLikelihoodOfEveryDraw) {
  const DmlNetwork net = loopy_network();
  std::mt19937_64 rng(11);
  DrawLog log;
  DmlRounds rounds(net, guesses_near_truth(net), 0.5);
  rounds.run(40, 80, rng, log);
  const auto [ml, fisher] = batch_ml(net, log);
  for (int i = 4; i < 7; ++i) {
    const auto estimate = rounds.estimate(i);
    ASSERT_TRUE(estimate.valid) << i;
    EXPECT_LT((estimate.mean_m - ml[static_cast<std::size_t>(i)]).norm(), 1e-6) << "agent " << i;
    EXPECT_GT((ml[static_cast<std::size_t>(i)] - net.truth[static_cast<std::size_t>(i)]).norm(), 1e-4);
    // Symmetric PD, and on this loopy graph within 30 % of the exact marginal variance.
    const Mat2& p = estimate.covariance;
    EXPECT_EQ(p(0, 1), p(1, 0));
    EXPECT_GT(p.determinant(), 0.0);
    const MatX exact = fisher.inverse();
    const double exact_trace = exact.block<2, 2>(2 * (i - 4), 2 * (i - 4)).trace();
    EXPECT_NEAR(p.trace() / exact_trace, 1.0, 0.3) << "agent " << i;
    EXPECT_FALSE(estimate.inconsistent) << i;
  }
}

TEST(Dml, StartsFromAnyGuessIntoTheSameSolution) {
  const DmlNetwork net = loopy_network();
  std::vector<Vec2> far_off = net.truth;
  for (auto& g : far_off) g = Vec2(-300.0, 450.0);  // nowhere near, and all the same
  std::mt19937_64 rng(12);
  DrawLog log;
  DmlRounds rounds(net, far_off, std::numeric_limits<double>::infinity());
  rounds.run(40, 80, rng, log);
  const auto ml = batch_ml(net, log).first;
  for (int i = 4; i < 7; ++i) {
    EXPECT_LT((rounds.estimate(i).mean_m - ml[static_cast<std::size_t>(i)]).norm(), 1e-6) << "agent " << i;
    EXPECT_FALSE(rounds.estimate(i).inconsistent) << i;
  }
}

TEST(Dml, CovarianceIsTheExactMarginalOnATree) {
  // Unknowns 3 and 4 share one edge; each also ranges to two anchors: a tree between the unknowns.
  DmlNetwork net;
  net.truth = {{0, 0}, {20, 0}, {30, 15}, {8, 9}, {20, 12}, {12, 24}};
  net.anchor = {true, true, true, false, false, true};
  net.edges = {{0, 3}, {5, 3}, {3, 4}, {1, 4}, {2, 4}};
  std::mt19937_64 rng(13);
  DrawLog log;
  DmlRounds rounds(net, guesses_near_truth(net), 0.5);
  rounds.run(30, 60, rng, log);
  const auto [ml, fisher] = batch_ml(net, log);
  const MatX exact = fisher.inverse();
  for (int i = 3; i < 5; ++i) {
    const Mat2 expected = exact.block<2, 2>(2 * (i - 3), 2 * (i - 3));
    const Mat2 got = rounds.estimate(i).covariance;
    EXPECT_LT((got - expected).norm(), 1e-9 * expected.norm()) << "agent " << i << "\n"
                                                               << got << "\n"
                                                               << expected;
  }
}

TEST(Dml, ReportsTheExactMarginalWhereItsNeighbourhoodHoldsTheLoops) {
  // Five agents ranging to each other hang on one anchor (5) and two long ranges to a far one (6): belief
  // propagation counts what goes round the cluster's loops more than once and is overconfident. Every
  // agent's neighbourhood holds the whole cluster, so the covariance it reports is the exact marginal.
  DmlNetwork net;
  net.truth = {{10, 10}, {13, 11}, {11, 14}, {14, 14}, {12, 17}, {7, 6}, {30, 2}};
  net.anchor = {false, false, false, false, false, true, true};
  for (int i = 0; i < 5; ++i)
    for (int j = i + 1; j < 5; ++j) net.edges.emplace_back(i, j);
  net.edges.insert(net.edges.end(), {{0, 5}, {1, 5}, {2, 5}, {1, 6}, {3, 6}});
  DmlRounds rounds(net, guesses_near_truth(net), 0.5);
  const MatX exact = exact_covariance_after_run(rounds, net, 17);
  for (int i = 0; i < 5; ++i) {
    const Mat2 expected = exact.block<2, 2>(2 * i, 2 * i);
    const Mat2 reported = rounds.estimate(i).covariance;
    EXPECT_LT((reported - expected).norm(), 1e-6 * expected.norm()) << "agent " << i << "\n"
                                                                    << reported << "\n"
                                                                    << expected;
    // What belief propagation alone publishes: at least 10 % overconfident (expected NEES 2 if exact).
    EXPECT_GT((rounds.published_covariance(i).inverse() * expected).trace(), 2.2) << "agent " << i;
  }
}

TEST(Dml, AGroupHangingOnTwoCloseAgentsReportsTheTurnItCanMake) {
  // Agents 6–9 range to each other; only 6 and 7 reach out, to agents 4 and 5, which sit a metre apart: the
  // group can turn about them, and belief propagation, counting the group's loops again and again, reports
  // it fixed to a few millimetres. Agents 8 and 9 have no neighbour outside the neighbourhoods of 6 and 7, so
  // those neighbourhoods hold everything that fixes 6 and 7: their covariance is the exact marginal.
  DmlNetwork net;
  net.truth = {{0, 0},     {30, 0},  {0, 30},  {30, 30}, {14, 12},
               {15, 12.5}, {12, 18}, {17, 19}, {13, 23}, {18, 24}};
  net.anchor = {true, true, true, true, false, false, false, false, false, false};
  for (int anchor = 0; anchor < 4; ++anchor) net.edges.insert(net.edges.end(), {{4, anchor}, {5, anchor}});
  net.edges.insert(net.edges.end(),
                   {{4, 5}, {6, 4}, {6, 5}, {7, 4}, {7, 5}, {6, 7}, {6, 8}, {6, 9}, {7, 8}, {7, 9}, {8, 9}});
  DmlRounds rounds(net, guesses_near_truth(net), 0.5);
  const MatX exact = exact_covariance_after_run(rounds, net, 37);
  for (int i = 6; i < 8; ++i) {
    SCOPED_TRACE(i);
    const Mat2 expected = exact.block<2, 2>(2 * (i - 4), 2 * (i - 4));
    // The trace to 2 %, the matrix to 10 % since the neighbours send their own cavities (docs/algorithms.md
    // §9.2).
    EXPECT_NEAR(rounds.estimate(i).covariance.trace(), expected.trace(), 0.05 * expected.trace());
    EXPECT_LT((rounds.estimate(i).covariance - expected).norm(), 0.15 * expected.norm())
        << rounds.estimate(i).covariance << "\n"
        << expected;
    EXPECT_GT((rounds.published_covariance(i).inverse() * expected).trace(), 4.0) << "belief propagation's";
  }
}

TEST(Dml, FlagsAnAgentItsRangesCannotPlaceUnambiguously) {
  // Agent 2 hears only two anchors: a mirror pair. An uninformed guess cannot pick; a good one can.
  DmlNetwork net;
  net.truth = {{0, 0}, {20, 0}, {9, 7}};
  net.anchor = {true, true, false};
  net.edges = {{0, 2}, {1, 2}};
  const int steps = 3 * static_cast<int>(Dml::kInitializationPatienceSteps) + 5;
  std::mt19937_64 rng(14);
  DrawLog log;
  DmlRounds uninformed(net, {net.truth[0], net.truth[1], Vec2(10.0, 1.0)},
                       std::numeric_limits<double>::infinity());
  uninformed.run(steps, 0, rng, log);
  EXPECT_TRUE(uninformed.estimate(2).valid);
  EXPECT_TRUE(uninformed.estimate(2).inconsistent);

  DmlRounds informed(net, {net.truth[0], net.truth[1], Vec2(9.4, 6.5)}, 0.5);
  informed.run(Dml::kInitializationPatienceSteps + 5, 0, rng, log);
  EXPECT_FALSE(informed.estimate(2).inconsistent);
  EXPECT_LT((informed.estimate(2).mean_m - net.truth[2]).norm(), 0.1);
}

TEST(Dml, NegativeConnectivityTellsAMirrorPairApart) {
  // Agent 2 hears only anchors 0 and 1 (a mirror pair across their line) and starts on the wrong side
  // with an uninformed guess. Anchor 3 is a neighbour of anchor 0 that agent 2 does not hear: within the
  // radius of the mirror image, so only the true side is possible.
  DmlNetwork net;
  net.truth = {{0, 0}, {20, 0}, {10, 6}, {6, -7}};
  net.anchor = {true, true, false, true};
  net.edges = {{0, 2}, {1, 2}, {0, 3}};
  constexpr double kRadiusM = 12.5;
  const std::vector<Vec2> guesses = {net.truth[0], net.truth[1], Vec2(10.0, -5.0), net.truth[3]};
  const int steps = static_cast<int>(Dml::kInitializationPatienceSteps) + 5;
  std::mt19937_64 rng(17);
  DrawLog log;
  DmlRounds graph_known(net, guesses, std::numeric_limits<double>::infinity(), kRadiusM);
  graph_known.run(steps, 0, rng, log);
  ASSERT_TRUE(graph_known.estimate(2).valid);
  EXPECT_LT((graph_known.estimate(2).mean_m - net.truth[2]).norm(), 0.1);
  EXPECT_FALSE(graph_known.estimate(2).inconsistent);
  // Without the radius the pair stays undecided until the guess has to pick (the mirror here), flagged.
  DmlRounds graph_unknown(net, guesses, std::numeric_limits<double>::infinity());
  graph_unknown.run(3 * steps, 0, rng, log);
  EXPECT_GT((graph_unknown.estimate(2).mean_m - net.truth[2]).norm(), 10.0);
  EXPECT_TRUE(graph_unknown.estimate(2).inconsistent);
}

/// Agents `first` onward (the pocket) each hold a valid estimate within 0.1 m of the truth, flagged or not.
void expect_pocket_placed(const DmlRounds& rounds, const DmlNetwork& net, int first, bool flagged) {
  for (int i = first; i < static_cast<int>(net.truth.size()); ++i) {
    SCOPED_TRACE(i);
    ASSERT_TRUE(rounds.estimate(i).valid);
    EXPECT_EQ(rounds.estimate(i).inconsistent, flagged);
    EXPECT_LT((rounds.estimate(i).mean_m - net.truth[static_cast<std::size_t>(i)]).norm(), 0.1);
  }
}

TEST(Dml, APocketNoAgentOfWhichHearsThreeAnchorsPlacesItselfFromItsLocalMap) {
  // Agents 3–5 each hear two anchors and each other: no one multilaterates, and with guesses that say
  // nothing each would wait out its patience and start from a guess on a mirror pair. Their neighbourhood's
  // map (the ranges the others relay, the third anchor's position through them) places each of them.
  DmlNetwork net;
  net.truth = {{0, 0}, {20, 0}, {10, 17}, {6, 5}, {14, 5}, {10, 11}};
  net.anchor = {true, true, true, false, false, false};
  net.edges = {{3, 0}, {3, 2}, {4, 1}, {4, 2}, {5, 0}, {5, 1}, {3, 4}, {4, 5}, {3, 5}};
  const Vec2 centre(10.0, 6.0);
  std::mt19937_64 rng(23);
  DrawLog log;
  DmlRounds pocket(net, {net.truth[0], net.truth[1], net.truth[2], centre, centre, centre},
                   std::numeric_limits<double>::infinity());
  pocket.run(static_cast<int>(Dml::kInitializationPatienceSteps) + 10, 0, rng, log);
  expect_pocket_placed(pocket, net, 3, false);
}

TEST(Dml, AnUndecidedPocketStartsFromTheMapPlaceNearerItsGuess) {
  // Only two anchors hold the pocket (agents 2–4): its mirror image across their line fits every range, and
  // without a radius the graph cannot rule it out. When the guesses must pick (after 150 steps), each agent
  // takes the place its map gives nearer its guess, flagged as an ambiguous start. Agents 2 and 3 hear one
  // anchor each: the point their guesses pick on that anchor's circle is 3.7 m off, and from there the pocket
  // is still 0.8 m off ten steps later.
  DmlNetwork net;
  net.truth = {{0, 0}, {20, 0}, {6, 5}, {14, 5}, {10, 11}};
  net.anchor = {true, true, false, false, false};
  net.edges = {{2, 0}, {3, 1}, {4, 0}, {4, 1}, {2, 3}, {3, 4}, {2, 4}};
  const std::vector<Vec2> guesses = {net.truth[0], net.truth[1], Vec2(9.0, 2.0), Vec2(11.0, 2.0),
                                     Vec2(10.0, 8.0)};
  std::mt19937_64 rng(29);
  DrawLog log;
  DmlRounds pocket(net, guesses, std::numeric_limits<double>::infinity());
  pocket.run(3 * static_cast<int>(Dml::kInitializationPatienceSteps) + 10, 0, rng, log);
  expect_pocket_placed(pocket, net, 2, true);
}

TEST(Dml, AGroupRigidOnlyWithItsNeighboursNeighboursReportsTheMarginalOfItsLocalMap) {
  // Agents 2–4 range to each other; anchor 0 holds 2 and 3, anchor 1 holds 4. Each agent has one rank-one
  // message from an anchor and none from the others (no one of them has a belief to send), so belief
  // propagation never gives one of them a belief. Each one's local map holds the whole network (anchor 1
  // through agent 4's relays): the covariance it reports is the exact marginal, linearized at its estimates
  // (within 1 %; at the batch solution it would be equal).
  DmlNetwork net;
  net.truth = {{0, 0}, {30, 2}, {8, 6}, {12, 4}, {11, 10}};
  net.anchor = {true, true, false, false, false};
  net.edges = {{2, 0}, {3, 0}, {4, 1}, {2, 3}, {3, 4}, {2, 4}};
  std::mt19937_64 rng(31);
  DrawLog log;
  DmlRounds rounds(net, guesses_near_truth(net), 0.5);
  rounds.run(3 * static_cast<int>(Dml::kInitializationPatienceSteps) + 20, 60, rng, log);
  const MatX exact = batch_ml(net, log).second.inverse();
  for (int i = 2; i < 5; ++i) {
    SCOPED_TRACE(i);
    EXPECT_GT(rounds.published_covariance(i).trace(), 1e6) << "belief propagation gives it no belief";
    ASSERT_TRUE(rounds.estimate(i).valid);
    const Mat2 expected = exact.block<2, 2>(2 * (i - 2), 2 * (i - 2));
    EXPECT_LT((rounds.estimate(i).covariance - expected).norm(), 1e-2 * expected.norm())
        << rounds.estimate(i).covariance << "\n"
        << expected;
  }
}

TEST(Dml, SelfCheckFlagsASolutionTheGraphContradicts) {
  // Agent 3 multilaterates from three anchors, but anchor 4 (relayed by anchor 0, not heard by agent 3)
  // lies 13.2 m from it: with a declared radius of 15 m the graph says it is farther. Its ranges fit.
  DmlNetwork net;
  net.truth = {{0, 0}, {20, 0}, {0, 16}, {8, 7}, {6, -6}};
  net.anchor = {true, true, true, false, true};
  net.edges = {{0, 3}, {1, 3}, {2, 3}, {0, 4}};
  std::mt19937_64 rng(18);
  DrawLog log;
  DmlRounds contradicted(net, guesses_near_truth(net), 0.5, 15.0);
  contradicted.run(30, 5, rng, log);
  EXPECT_LT((contradicted.estimate(3).mean_m - net.truth[3]).norm(), 0.1);
  EXPECT_TRUE(contradicted.estimate(3).inconsistent);
  DmlRounds consistent(net, guesses_near_truth(net), 0.5, 13.0);  // the graph is this radius's disk graph
  consistent.run(30, 5, rng, log);
  EXPECT_FALSE(consistent.estimate(3).inconsistent);
}

TEST(DmlTwoHop, KeepsRelayedPositionsThatFitTheSendersRangeAndDropsGarbledOnes) {
  TwoHopPositions two_hop(10.0);
  const Vec2 sender(0.0, 0.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<EdgeRangeSummary> relayed = {
      {5, 100.0, 8.0, Vec2(0.0, 8.05)},   // kept: 8.05 m away, the sender's range says 8.0
      {6, 100.0, 3.0, Vec2(0.0, 8.0)},    // garbled: the position is 5 m off the sender's own range
      {7, 100.0, 12.0, Vec2(12.0, 0.0)},  // garbled: beyond the radius of its relayer
      {8, 100.0, 4.0, Vec2(nan, 4.0)},    // not finite
      {9, 100.0, 4.0, sender},            // the sender's own mean: it does not know agent 9's
      {1, 100.0, 4.0, Vec2(4.0, 0.0)},    // about the receiver itself
      {4, 0.0, 4.0, Vec2(4.0, 0.0)},      // no draws behind it
  };
  EXPECT_EQ(two_hop.absorb(1, sender, relayed), 1);
  EXPECT_EQ(two_hop.size(), 1u);
  const auto hears_nobody = [](AgentId) { return false; };
  EXPECT_NEAR(two_hop.penetration(Vec2(0.0, 5.0), hears_nobody), 10.0 - 3.05, 1e-12);
  EXPECT_EQ(two_hop.penetration(Vec2(0.0, 5.0), [](AgentId id) { return id == 5; }),
            -std::numeric_limits<double>::infinity());
  // An unknown radius keeps nothing: the graph says nothing about distances then.
  TwoHopPositions unknown(std::numeric_limits<double>::infinity());
  EXPECT_EQ(unknown.absorb(1, sender, relayed), 0);
  EXPECT_FALSE(unknown.enabled());
}

TEST(Dml, RangesThroughANeighbourTellAMirrorPairApart) {
  // Agent 2 hears anchors 0 and 1 (a mirror pair across their line) and agent 3, which hears only agent 2
  // and anchor 4 and cannot localize before agent 2 does. Agent 3 relays its range to anchor 4: agent 2 is
  // within r_23 + r_34 = 17.0 m of anchor 4 (the truth 16.1 m, the mirror image 27.2 m). No graph helps:
  // no localized neighbour relays anchor 4, and the guess is uninformed and on the mirror side.
  DmlNetwork net;
  net.truth = {{0, 0}, {20, 0}, {10, 6}, {12, 15}, {18, 20}};
  net.anchor = {true, true, false, false, true};
  net.edges = {{0, 2}, {1, 2}, {2, 3}, {3, 4}};
  const std::vector<Vec2> guesses = {net.truth[0], net.truth[1], Vec2(10.0, -5.0), Vec2(12.0, -14.0),
                                     net.truth[4]};
  std::mt19937_64 rng(19);
  DrawLog log;
  DmlRounds rounds(net, guesses, std::numeric_limits<double>::infinity(), 12.5);
  rounds.run(static_cast<int>(Dml::kInitializationPatienceSteps) + 5, 0, rng, log);
  ASSERT_TRUE(rounds.estimate(2).valid);
  EXPECT_LT((rounds.estimate(2).mean_m - net.truth[2]).norm(), 0.1);
  EXPECT_FALSE(rounds.estimate(2).inconsistent);
}

TEST(DmlRelayedRanges, BoundsTheDistanceToARelayedAgentByTheTriangleInequality) {
  RelayedRanges relays;
  const Vec2 sender(0.0, 0.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  relays.absorb(1, 3, sender,
                {{5, 100.0, 4.0, Vec2(4.0, 0.0)},  // kept: agent 5 is 4 m from agent 3
                 {6, 100.0, 4.0, sender},          // the sender's own mean: it does not know agent 6's
                 {7, 100.0, 4.0, Vec2(nan, 0.0)},  // not finite
                 {1, 100.0, 4.0, Vec2(4.0, 0.0)},  // about the receiver itself
                 {8, 0.0, 4.0, Vec2(4.0, 0.0)}});  // no draws behind it
  const auto three_m_from_agent_3 = [](AgentId via) { return via == 3 ? 3.0 : -1.0; };
  // Agent 1 is 3 m from agent 3 and agent 3 is 4 m from agent 5: agent 1 is 1 to 7 m from agent 5.
  EXPECT_NEAR(relays.violation(Vec2(4.0, 9.0), three_m_from_agent_3), 9.0 - 7.0, 1e-12);
  EXPECT_NEAR(relays.violation(Vec2(4.0, 0.5), three_m_from_agent_3), 1.0 - 0.5, 1e-12);
  EXPECT_NEAR(relays.violation(Vec2(4.0, 3.0), three_m_from_agent_3), -2.0, 1e-12);
  EXPECT_EQ(relays.violation(Vec2(4.0, 9.0), [](AgentId) { return -1.0; }),
            -std::numeric_limits<double>::infinity());
}

TEST(DmlRelayedRanges, VisitsWhatTheGivenAgentsRelayedOfTheirRangesToEachOther) {
  RelayedRanges relays;
  relays.absorb(1, 3, Vec2(0, 0),
                {{5, 10.0, 4.0, Vec2(4, 0)}, {7, 20.0, 4.0, Vec2(0, 4)}, {9, 30.0, 5.0, Vec2(3, 4)}});
  relays.absorb(1, 5, Vec2(4, 0), {{3, 60.0, 4.0, Vec2(0, 0)}});
  relays.absorb(1, 7, Vec2(0, 4), {{3, 40.0, 4.0, Vec2(0, 0)}, {5, 50.0, 5.7, Vec2(4, 0)}});
  std::vector<std::tuple<std::size_t, std::size_t, double>> visited;
  relays.for_each_information_among({3, 7, 9}, [&visited](std::size_t p, std::size_t q, double information) {
    visited.emplace_back(p, q, information);
  });
  // 3→7, 3→9 and 7→3; agent 5 is not among them, as sender or as peer.
  const std::vector<std::tuple<std::size_t, std::size_t, double>> expected{
      {0, 1, 20.0}, {0, 2, 30.0}, {1, 0, 40.0}};
  EXPECT_EQ(visited, expected);
}

TEST(DmlRegion, AStaleMessageTakesOutNoMoreThanTheNeighboursBeliefHolds) {
  // The centre hears two anchors (x and y) and one neighbour along x with belief precision 100 there. Had it
  // sent that neighbour 50 along x, 50 of the neighbour's 100 come from outside; a message of 150 (stale,
  // larger than the belief) leaves nothing outside, not −50.
  const std::vector<region::Known> anchors{{Vec2(-10, 0), 100.0}, {Vec2(0, -10), 100.0}};
  const auto centre = [&anchors](double sent_scale) {
    const std::vector<region::Member> members{{Vec2(10, 0), 0.01 * Mat2::Identity(), 200.0, sent_scale}};
    return region::centre_covariance(Vec2::Zero(), Mat2::Zero(), members, {}, anchors);
  };
  ASSERT_TRUE(centre(50.0).has_value());
  // Along x: 100 from the anchor + the neighbour's range (200) against its outside 50: 200·50/250 = 40.
  EXPECT_NEAR((*centre(50.0))(0, 0), 1.0 / 140.0, 1e-12);
  ASSERT_TRUE(centre(150.0).has_value());
  EXPECT_NEAR((*centre(150.0))(0, 0), 1.0 / 100.0, 1e-12);  // nothing from outside: the range adds nothing
  EXPECT_NEAR((*centre(150.0))(1, 1), 1.0 / 100.0, 1e-12);
}

TEST(Dml, SelfCheckFlagsRangesItsSolutionCannotExplain) {
  DmlNetwork net;
  net.truth = {{8, 7}, {0, 0}, {20, 0}, {0, 20}, {20, 20}};
  net.anchor = {false, true, true, true, true};
  net.edges = {{0, 1}, {0, 2}, {0, 3}, {0, 4}};
  std::mt19937_64 rng(15);
  DrawLog log;
  DmlRounds honest(net, guesses_near_truth(net), 0.5);
  honest.run(50, 5, rng, log);
  EXPECT_FALSE(honest.estimate(0).inconsistent);
  DmlRounds biased(net, guesses_near_truth(net), 0.5);
  biased.run(50, 5, rng, log, 1.0);  // one sensor reads 1 m long, 10σ
  EXPECT_TRUE(biased.estimate(0).inconsistent);
}

TEST(Dml, AnAgentThatRestsOnAFlaggedNeighbourIsFlaggedToo) {
  // Agent 5 hears only anchor 2 and agent 0, and its guess picks the side: two ranges, fitted exactly, so
  // its own checks pass whatever agent 0 does. When one of agent 0's sensors reads 1 m long, agent 0 flags
  // itself, and agent 5, with fewer than three unflagged references, is flagged with it.
  DmlNetwork net;
  net.truth = {{8, 7}, {0, 0}, {20, 0}, {0, 20}, {20, 20}, {26, 12}};
  net.anchor = {false, true, true, true, true, false};
  net.edges = {{0, 1}, {0, 2}, {0, 3}, {0, 4}, {0, 5}, {2, 5}};
  const int data_steps = static_cast<int>(Dml::kInitializationPatienceSteps) + 10;
  std::mt19937_64 rng(19);
  DrawLog log;
  DmlRounds honest(net, guesses_near_truth(net), 0.5);
  honest.run(data_steps, 5, rng, log);
  ASSERT_TRUE(honest.estimate(5).valid);
  EXPECT_FALSE(honest.estimate(0).inconsistent);
  EXPECT_FALSE(honest.estimate(5).inconsistent);
  DmlRounds biased(net, guesses_near_truth(net), 0.5);
  biased.run(data_steps, 5, rng, log, 1.0);
  ASSERT_TRUE(biased.estimate(5).valid);
  EXPECT_TRUE(biased.estimate(0).inconsistent);
  EXPECT_TRUE(biased.estimate(5).inconsistent);
}

TEST(Dml, ARepeatedReadingCountsOnce) {
  const DmlNetwork net = loopy_network();
  std::mt19937_64 rng(16);
  DrawLog once_log;
  DmlRounds once(net, guesses_near_truth(net), 0.5);
  once.run(1, 80, rng, once_log);
  DrawLog repeated_log;
  DmlRounds repeated(net, guesses_near_truth(net), 0.5);
  repeated.repeat_first_draws();
  std::mt19937_64 same_rng(16);
  repeated.run(40, 40, same_rng, repeated_log);
  for (int i = 4; i < 7; ++i) {
    EXPECT_LT((repeated.estimate(i).covariance - once.estimate(i).covariance).norm(),
              1e-9 * once.estimate(i).covariance.norm())
        << "agent " << i;
    EXPECT_LT((repeated.estimate(i).mean_m - once.estimate(i).mean_m).norm(), 1e-9) << "agent " << i;
  }
}

}  // namespace
}  // namespace swarmloc::estimators
