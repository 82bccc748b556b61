#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <memory>
#include <random>
#include <vector>

#include "eigen_gtest.hpp"
#include "named_estimators.hpp"
#include "swarmloc/estimators/consensus/jacobi.hpp"

namespace swarmloc::estimators::consensus {
namespace {

struct Edge {
  int i;
  int j;
};

// Synchronous rounds: every agent steps on the STATEs published in the previous round.
class TestBus {
 public:
  explicit TestBus(int n) : inboxes_(static_cast<std::size_t>(n)), states_(static_cast<std::size_t>(n)) {}
  void round(std::vector<std::unique_ptr<JacobiLocalization>>& agents, const std::vector<Edge>& edges,
             const std::vector<MeasurementBatch>* batches, std::int64_t step) {
    for (auto& inbox : inboxes_) inbox.states.clear();
    for (const Edge& e : edges) {
      inboxes_[static_cast<std::size_t>(e.i)].states.push_back(
          {e.j, step - 1, states_[static_cast<std::size_t>(e.j)]});
      inboxes_[static_cast<std::size_t>(e.j)].states.push_back(
          {e.i, step - 1, states_[static_cast<std::size_t>(e.i)]});
    }
    for (std::size_t i = 0; i < agents.size(); ++i) {
      const StepInput input{step, batches ? &(*batches)[i] : nullptr, &inboxes_[i]};
      states_[i] = *agents[i]->step(input).outbox.state;
    }
  }
  void init(const std::vector<std::unique_ptr<JacobiLocalization>>& agents) {
    for (std::size_t i = 0; i < agents.size(); ++i) states_[i] = *agents[i]->initial_outbox().state;
  }

 private:
  std::vector<Inbox> inboxes_;
  std::vector<StateMessage> states_;
};

// A small connected graph: a 3×3 grid plus two diagonals.
struct SmallNetwork {
  std::vector<Vec2> truth;
  std::vector<Edge> edges;
  SmallNetwork() {
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) truth.emplace_back(2.0 * c + 0.1 * r, 2.0 * r - 0.2 * c);
    }
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) {
        if (c < 2) edges.push_back({3 * r + c, 3 * r + c + 1});
        if (r < 2) edges.push_back({3 * r + c, 3 * r + c + 3});
      }
    }
    edges.push_back({0, 4});
    edges.push_back({4, 8});
    const Vec2 origin = truth[0];
    for (auto& x : truth) x -= origin;
  }
};

TEST(Jacobi, FixedPointEqualsTheCentralizedBlue) {
  const SmallNetwork net;
  const int n = static_cast<int>(net.truth.size());
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal(0.0, 0.3);
  std::vector<std::unique_ptr<JacobiLocalization>> agents;
  for (int i = 0; i < n; ++i) {
    AgentSetup setup;
    setup.id = i;
    setup.anchor = i == 0;
    setup.initial_guess_m =
        i == 0 ? Vec2::Zero() : Vec2(net.truth[static_cast<std::size_t>(i)] + Vec2(3.0, -2.0));
    agents.push_back(std::make_unique<JacobiLocalization>(setup));
  }
  // Heterogeneous edge covariances 𝓔_ij; shared samples s_ji = −s_ij ([C-7]).
  std::vector<Mat2> cov;
  for (std::size_t k = 0; k < net.edges.size(); ++k) {
    Mat2 c;
    c << 0.5 + 0.1 * static_cast<double>(k), 0.1, 0.1, 0.3 + 0.05 * static_cast<double>(k % 3);
    cov.push_back(c);
  }
  std::vector<Vec2> sum(net.edges.size(), Vec2::Zero());
  TestBus bus(n);
  bus.init(agents);
  const int samples = 4;
  for (int t = 0; t < samples; ++t) {
    std::vector<MeasurementBatch> batches(static_cast<std::size_t>(n));
    for (std::size_t k = 0; k < net.edges.size(); ++k) {
      const auto [i, j] = net.edges[k];
      const Vec2 s = net.truth[static_cast<std::size_t>(j)] - net.truth[static_cast<std::size_t>(i)] +
                     Vec2(normal(rng), normal(rng));
      sum[k] += s;
      batches[static_cast<std::size_t>(i)].relative.push_back({j, s, cov[k]});
      batches[static_cast<std::size_t>(j)].relative.push_back({i, -s, cov[k]});
    }
    bus.round(agents, net.edges, &batches, t);
  }
  for (int t = samples; t < 3000; ++t)
    bus.round(agents, net.edges, nullptr, t);  // s̄ frozen: iterate to the fixed point

  // BLUE (Atanasov et al. eq. (8)): minimize Σ (x_j − x_i − s̄_ij)ᵀ𝓔_ij⁻¹(·) with x_0 = 0.
  const int m = n - 1;
  MatX L = MatX::Zero(2 * m, 2 * m);
  VecX b = VecX::Zero(2 * m);
  for (std::size_t k = 0; k < net.edges.size(); ++k) {
    const int a = net.edges[k].i - 1;
    const int c = net.edges[k].j - 1;
    const Mat2 E = cov[k].inverse();
    const Vec2 mean = sum[k] / samples;
    if (a >= 0) {
      L.block<2, 2>(2 * a, 2 * a) += E;
      b.segment<2>(2 * a) -= E * mean;
    }
    if (c >= 0) {
      L.block<2, 2>(2 * c, 2 * c) += E;
      b.segment<2>(2 * c) += E * mean;
    }
    if (a >= 0 && c >= 0) {
      L.block<2, 2>(2 * a, 2 * c) -= E;
      L.block<2, 2>(2 * c, 2 * a) -= E;
    }
  }
  const VecX blue = L.llt().solve(b);
  EXPECT_MATRIX_NEAR(agents[0]->mean(), Vec2::Zero(), 0.0);
  for (int i = 1; i < n; ++i) {
    EXPECT_MATRIX_NEAR(agents[static_cast<std::size_t>(i)]->mean(), Vec2(blue.segment<2>(2 * (i - 1))), 1e-6);
  }
}

TEST(Jacobi, RunningMeanAveragesAllSamplesIncludingTheFirst) {  // [C-3]
  AgentSetup setup;
  setup.id = 1;
  JacobiLocalization node(setup);
  Inbox inbox;
  inbox.states.push_back({0, 0, StateMessage{}});  // reference at 0
  MeasurementBatch batch;
  for (const double s : {1.0, 2.0, 6.0}) {
    batch.relative = {RelativeMeasurement{0, Vec2(s, 0.0), Mat2::Identity()}};
    node.step(StepInput{0, &batch, &inbox});
  }
  // x_1 = x_0 − s̄ with s̄ = (1 + 2 + 6)/3 = 3.
  EXPECT_MATRIX_NEAR(node.mean(), Vec2(-3.0, 0.0), 1e-12);
  EXPECT_EQ(node.edges().at(0).count, 3);
}

TEST(Jacobi, ReferenceNodeNeverMoves) {
  AgentSetup setup;
  setup.id = 0;
  setup.anchor = true;
  JacobiLocalization node(setup);
  Inbox inbox;
  StateMessage far;
  far.mean_m = Vec2(10.0, 10.0);
  inbox.states.push_back({1, 0, far});
  MeasurementBatch batch;
  batch.relative = {RelativeMeasurement{1, Vec2(1.0, 1.0), Mat2::Identity()}};
  const StepOutput out = node.step(StepInput{0, &batch, &inbox});
  EXPECT_MATRIX_NEAR(node.mean(), Vec2::Zero(), 0.0);
  ASSERT_TRUE(out.outbox.state.has_value());
  EXPECT_TRUE(out.outbox.state->anchor);
  EXPECT_MATRIX_NEAR(out.outbox.state->covariance, Mat2::Zero(), 0.0);
}

TEST(CooperativeFactory, BuildsEveryNamedAlgorithmAndRejectsUnknownNames) {
  AgentSetup setup;
  for (const auto& name : testing::cooperative_algorithms()) {
    const auto estimator = config::make_estimator(name, setup, EstimatorParams{});
    ASSERT_NE(estimator, nullptr);
    EXPECT_EQ(estimator->name(), name);
  }
  EXPECT_THROW((void)config::make_estimator("nope", setup, EstimatorParams{}), std::invalid_argument);
}

}  // namespace
}  // namespace swarmloc::estimators::consensus
