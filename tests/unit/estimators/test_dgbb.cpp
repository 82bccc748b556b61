#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "eigen_gtest.hpp"
#include "swarmloc/estimators/gradient/dgbb.hpp"

namespace swarmloc::estimators::gradient {
namespace {

// Newest-per-sender mailboxes over a fixed graph; one round delivers the previous round's outboxes.
class Mailboxes {
 public:
  explicit Mailboxes(std::vector<std::vector<int>> adjacency)
      : adjacency_(std::move(adjacency)), inboxes_(adjacency_.size()) {}
  void deliver(std::size_t sender, std::int64_t step, const Outbox& out) {
    for (const int r : adjacency_[sender]) {
      Inbox& box = inboxes_[static_cast<std::size_t>(r)];
      if (out.state) put(box.states, static_cast<AgentId>(sender), step, *out.state);
      if (!out.consensus.empty())
        put(box.consensus, static_cast<AgentId>(sender), step, out.consensus.back());
    }
  }
  void round(std::vector<std::unique_ptr<DgBb>>& agents, std::int64_t step,
             const std::vector<MeasurementBatch>* batches) {
    std::vector<Outbox> outs;
    for (std::size_t i = 0; i < agents.size(); ++i) {
      outs.push_back(
          agents[i]->step(StepInput{step, batches ? &(*batches)[i] : nullptr, &inboxes_[i]}).outbox);
    }
    for (std::size_t i = 0; i < agents.size(); ++i) deliver(i, step, outs[i]);
  }

 private:
  template <typename M>
  static void put(std::vector<Received<M>>& list, AgentId sender, std::int64_t step, const M& m) {
    for (auto& e : list) {
      if (e.sender == sender) {
        e = Received<M>{sender, step, m};
        return;
      }
    }
    list.push_back(Received<M>{sender, step, m});
  }
  std::vector<std::vector<int>> adjacency_;
  std::vector<Inbox> inboxes_;
};

// k×k lattice on [0,1]² with one diagonal per cell, anchors at the corners, noiseless ranges.
struct Lattice {
  RangeProblem problem;
  std::vector<Vec2> truth;
  std::vector<std::vector<int>> adjacency;
  std::vector<MeasurementBatch> batches;
  Lattice(int k, double initial_std, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> normal(0.0, initial_std);
    const int n = k * k;
    adjacency.resize(static_cast<std::size_t>(n));
    batches.resize(static_cast<std::size_t>(n));
    for (int r = 0; r < k; ++r) {
      for (int c = 0; c < k; ++c) truth.emplace_back(c / (k - 1.0), r / (k - 1.0));
    }
    problem.anchor.assign(static_cast<std::size_t>(n), false);
    for (const int a : {0, k - 1, n - k, n - 1}) problem.anchor[static_cast<std::size_t>(a)] = true;
    auto edge = [&](int i, int j) {
      const double d = (truth[static_cast<std::size_t>(i)] - truth[static_cast<std::size_t>(j)]).norm();
      problem.edges.push_back({i, j, d});
      adjacency[static_cast<std::size_t>(i)].push_back(j);
      adjacency[static_cast<std::size_t>(j)].push_back(i);
      batches[static_cast<std::size_t>(i)].ranges.push_back({j, d, 0.0});
      batches[static_cast<std::size_t>(j)].ranges.push_back({i, d, 0.0});
    };
    for (int r = 0; r < k; ++r) {
      for (int c = 0; c < k; ++c) {
        if (c + 1 < k) edge(r * k + c, r * k + c + 1);
        if (r + 1 < k) edge(r * k + c, (r + 1) * k + c);
        if (r + 1 < k && c + 1 < k) edge(r * k + c, (r + 1) * k + c + 1);
      }
    }
    problem.initial = truth;
    for (std::size_t i = 0; i < truth.size(); ++i) {
      if (!problem.anchor[i]) {
        const double x = normal(rng);
        problem.initial[i] += Vec2(x, normal(rng));
      }
    }
  }
  std::vector<std::unique_ptr<DgBb>> agents(const DgBbParams& params) const {
    std::vector<std::unique_ptr<DgBb>> out;
    for (std::size_t i = 0; i < truth.size(); ++i) {
      AgentSetup setup;
      setup.id = static_cast<AgentId>(i);
      setup.anchor = problem.anchor[i];
      setup.initial_guess_m = problem.initial[i];
      out.push_back(std::make_unique<DgBb>(setup, params));
    }
    return out;
  }
};

TEST(DgBb, ConsensusStepConvergesToTheCentralizedBbStep) {  // Calafiore et al. Prop. 1
  const Lattice lattice(4, 0.05, 9);
  DgBbParams params;
  params.consensus_rounds = 150;
  auto agents = lattice.agents(params);
  Mailboxes bus(lattice.adjacency);
  for (std::size_t i = 0; i < agents.size(); ++i) bus.deliver(i, -1, agents[i]->initial_outbox());
  // Round 0: warm-up; round 1: ρ(0), ψ(0); rounds 2…T+1: consensus, the last one updates.
  for (int step = 0; step < params.consensus_rounds + 2; ++step) {
    bus.round(agents, step, step == 0 ? &lattice.batches : nullptr);
  }
  // The same first BB step computed centrally from p^(0), p^(1) = p^(0) − α̃ D(p^(0)).
  const auto& p0 = lattice.problem.initial;
  const auto D0 = direction(lattice.problem, p0);
  std::vector<Vec2> p1 = p0;
  for (std::size_t i = 0; i < p1.size(); ++i) p1[i] -= params.warmup_step * D0[i];
  const auto D1 = direction(lattice.problem, p1);
  std::vector<Vec2> dp(p0.size());
  std::vector<Vec2> dD(p0.size());
  for (std::size_t i = 0; i < p0.size(); ++i) {
    dp[i] = p1[i] - p0[i];
    dD[i] = D1[i] - D0[i];
  }
  const double alpha = centralized_bb_step(dp, dD);
  ASSERT_TRUE(std::isfinite(alpha) && alpha > 0.0);
  for (std::size_t i = 0; i < agents.size(); ++i) {
    EXPECT_EQ(agents[i]->updates(), 2);
    EXPECT_NEAR(agents[i]->rho() / agents[i]->psi(), alpha, 1e-6 * alpha) << "node " << i;
    if (!lattice.problem.anchor[i]) {
      EXPECT_NEAR(agents[i]->last_step(), alpha, 1e-6 * alpha);
      EXPECT_MATRIX_NEAR(agents[i]->position(), Vec2(p1[i] - alpha * D1[i]), 1e-7);
    }
  }
}

TEST(DgBb, FewConsensusRoundsLeaveTheStepsDisagreeing) {  // the Prop. 1 test above can fail
  const Lattice lattice(4, 0.05, 9);
  DgBbParams params;
  params.consensus_rounds = 1;
  auto agents = lattice.agents(params);
  Mailboxes bus(lattice.adjacency);
  for (std::size_t i = 0; i < agents.size(); ++i) bus.deliver(i, -1, agents[i]->initial_outbox());
  for (int step = 0; step < params.consensus_rounds + 2; ++step) {
    bus.round(agents, step, step == 0 ? &lattice.batches : nullptr);
  }
  double lo = 1e300;
  double hi = 0.0;
  for (std::size_t i = 0; i < agents.size(); ++i) {
    if (lattice.problem.anchor[i]) continue;
    lo = std::min(lo, agents[i]->last_step());
    hi = std::max(hi, agents[i]->last_step());
  }
  EXPECT_GT(hi / lo, 1.01);
}

TEST(DgBb, ConvergesToTheTrueLatticeAndStops) {
  const Lattice lattice(4, 0.05, 2);
  DgBbParams params;
  params.consensus_rounds = 10;
  auto agents = lattice.agents(params);
  Mailboxes bus(lattice.adjacency);
  for (std::size_t i = 0; i < agents.size(); ++i) bus.deliver(i, -1, agents[i]->initial_outbox());
  int step = 0;
  for (; step < 20000; ++step) {
    bus.round(agents, step, step == 0 ? &lattice.batches : nullptr);
    bool any = false;
    for (const auto& a : agents) any = any || a->active();
    if (!any) break;
  }
  EXPECT_LT(step, 20000);
  for (std::size_t i = 0; i < agents.size(); ++i)
    EXPECT_MATRIX_NEAR(agents[i]->position(), lattice.truth[i], 1e-6);
}

TEST(CentralizedBb, RecoversTheNoiselessLattice) {
  const Lattice lattice(5, 0.05, 4);
  DgBbParams params;
  const CentralizedBbResult result = centralized_bb(lattice.problem, params);
  EXPECT_LT(result.updates, params.max_updates);
  for (std::size_t i = 0; i < lattice.truth.size(); ++i) {
    EXPECT_MATRIX_NEAR(result.positions[i], lattice.truth[i], 1e-6);
  }
  EXPECT_LT(objective(lattice.problem, result.positions), 1e-16);
}

TEST(DgBb, DirectionIsHalfTheGradient) {  // [E-1]: D = ½∇f, checked by central differences
  const Lattice lattice(3, 0.1, 1);
  const auto& p = lattice.problem.initial;
  const auto D = direction(lattice.problem, p);
  const double h = 1e-6;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (lattice.problem.anchor[i]) continue;
    for (int axis = 0; axis < 2; ++axis) {
      auto plus = p;
      auto minus = p;
      plus[i](axis) += h;
      minus[i](axis) -= h;
      const double grad = (objective(lattice.problem, plus) - objective(lattice.problem, minus)) / (2.0 * h);
      EXPECT_NEAR(D[i](axis), 0.5 * grad, 1e-7);
    }
  }
}

TEST(DgBb, StepCapBoundsEveryLocalBbStep) {  // max_step (not in the source)
  const Lattice lattice(4, 0.05, 3);
  DgBbParams params;
  params.rule = StepRule::kLocalBb;
  params.max_step = 0.5;
  auto agents = lattice.agents(params);
  Mailboxes bus(lattice.adjacency);
  for (std::size_t i = 0; i < agents.size(); ++i) bus.deliver(i, -1, agents[i]->initial_outbox());
  double largest = 0.0;
  for (int step = 0; step < 40; ++step) {
    bus.round(agents, step, step == 0 ? &lattice.batches : nullptr);
    for (std::size_t i = 0; i < agents.size(); ++i) {
      if (!lattice.problem.anchor[i] && step > 0) largest = std::max(largest, agents[i]->last_step());
    }
  }
  EXPECT_LE(largest, 0.5);
  EXPECT_GT(largest, 0.0);
}

TEST(DgBb,
     TrustRegionBoundsEveryBbMoveByAFractionOfTheShortestRange) {  // max_move_fraction (not in the source)
  const Lattice lattice(4, 0.05, 3);
  DgBbParams params;
  params.rule = StepRule::kLocalBb;
  params.max_move_fraction = 0.1;
  const double max_move = 0.1 / 3.0;  // shortest range on the 4 × 4 unit lattice: 1/3
  auto agents = lattice.agents(params);
  Mailboxes bus(lattice.adjacency);
  for (std::size_t i = 0; i < agents.size(); ++i) bus.deliver(i, -1, agents[i]->initial_outbox());
  double largest = 0.0;
  for (int step = 0; step < 60; ++step) {
    std::vector<Vec2> before;
    for (const auto& agent : agents) before.push_back(agent->position());
    bus.round(agents, step, step == 0 ? &lattice.batches : nullptr);
    for (std::size_t i = 0; i < agents.size(); ++i)
      largest = std::max(largest, (agents[i]->position() - before[i]).norm());
  }
  int cuts = 0;
  for (const auto& agent : agents) cuts += agent->trust_region_count();
  EXPECT_LE(largest, max_move * (1.0 + 1e-12));
  EXPECT_GT(cuts, 0) << "the region never bound: the test would not see a broken cap";
}

TEST(DgBb, RejectsInvalidParameters) {
  DgBbParams params;
  params.consensus_rounds = -1;
  EXPECT_THROW(validate(params), std::invalid_argument);
  params = DgBbParams{};
  params.grad_scale = 3.0;
  EXPECT_THROW(DgBb(AgentSetup{}, params), std::invalid_argument);
  params = DgBbParams{};
  params.max_move_fraction = -1.0;
  EXPECT_THROW(validate(params), std::invalid_argument);
}

}  // namespace
}  // namespace swarmloc::estimators::gradient
