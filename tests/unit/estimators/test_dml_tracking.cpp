// dml_track (docs/algorithms.md §9.8) against the centralized Kalman filter and smoother of the same draws on
// collinear chains, where the linearized range is exact along the line and belief propagation on a tree is
// exact: the one-agent filter, the cavity on a chain, a late draw at its own step once, the window's
// marginals, and a symmetric PSD covariance.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <memory>
#include <vector>

#include "swarmloc/estimators/dml/tracking.hpp"

namespace swarmloc::estimators {
namespace dml_tracking_test {  // named: the unity build joins this file with test_dml.cpp

constexpr double kRangeStdM = 0.5;
constexpr double kGuessStdM = 2.0;
constexpr double kProcessStdM = 0.1;

/// One DmlTracking per agent, stepped in synchronous rounds: each round every agent takes the others'
/// previous-round beliefs (minus `held`: senders whose newer samples are lost).
class Rounds {
 public:
  Rounds(const std::vector<Vec2>& guesses, const std::vector<bool>& anchor) {
    KalmanFilterParams params;
    params.process_noise_std_m = kProcessStdM;
    for (std::size_t i = 0; i < guesses.size(); ++i) {
      AgentSetup setup;
      setup.id = static_cast<AgentId>(i);
      setup.anchor = anchor[i];
      setup.initial_guess_m = guesses[i];
      setup.initial_guess_std_m = kGuessStdM;
      agents_.push_back(std::make_unique<DmlTracking>(setup, params));
      outboxes_.push_back(agents_.back()->initial_outbox());
    }
  }

  /// One round. `ranges[i]`: agent i's draws (peer → range) on a world step, or none (an exchange).
  void round(std::int64_t world_step, const std::map<int, std::map<int, double>>& ranges, bool with_batch) {
    std::vector<Outbox> next(agents_.size());
    for (std::size_t i = 0; i < agents_.size(); ++i) {
      Inbox inbox;
      for (std::size_t j = 0; j < agents_.size(); ++j) {
        if (j == i || !outboxes_[j].belief) continue;
        const auto held_it = held_.find(static_cast<int>(j));
        const BeliefMessage& message = held_it != held_.end() ? held_it->second : *outboxes_[j].belief;
        inbox.beliefs.push_back({static_cast<AgentId>(j), 0, message});
      }
      MeasurementBatch batch;
      batch.world_step = world_step;
      if (const auto it = ranges.find(static_cast<int>(i)); it != ranges.end()) {
        for (const auto& [peer, range] : it->second) batch.ranges.push_back({peer, range, kRangeStdM});
      }
      StepInput input;
      input.local_step = steps_;
      input.measurements = with_batch ? &batch : nullptr;
      input.inbox = &inbox;
      next[i] = agents_[i]->step(input).outbox;
    }
    outboxes_ = std::move(next);
    ++steps_;
  }

  /// From now on the others see agent `j`'s current belief only (its newer samples are lost).
  void hold(int j) { held_[j] = *outboxes_[static_cast<std::size_t>(j)].belief; }

  [[nodiscard]] Estimate estimate(int i) const { return agents_[static_cast<std::size_t>(i)]->estimate(); }
  [[nodiscard]] const BeliefMessage& belief(int i) const {
    return *outboxes_[static_cast<std::size_t>(i)].belief;
  }

 private:
  std::vector<std::unique_ptr<DmlTracking>> agents_;
  std::vector<Outbox> outboxes_;
  std::map<int, BeliefMessage> held_;
  std::int64_t steps_ = 0;
};

double variance(double std_m) { return std_m * std_m; }

// An exactly known anchor at the origin and one moving agent on the x-axis, both ranging each step: the
// agent's x is the scalar Kalman filter with both draws (information 2/σ² per step), its y only predicts.
TEST(DmlTracking, OneAgentWithAnAnchorIsTheKalmanFilterOfBothDraws) {
  Rounds rounds({Vec2(0.0, 0.0), Vec2(10.0, 0.0)}, {true, false});
  double mean = 10.0;
  double var_x = variance(kGuessStdM);
  double var_y = variance(kGuessStdM);
  const double ranges[][2] = {{9.6, 9.9}, {10.4, 10.1}, {9.8, 10.5}, {10.2, 10.0}, {9.7, 9.9}};
  for (std::int64_t k = 0; k < 5; ++k) {
    const std::map<int, std::map<int, double>> draws{{0, {{1, ranges[k][0]}}}, {1, {{0, ranges[k][1]}}}};
    rounds.round(k, draws, true);
    for (int extra = 0; extra < 2; ++extra) rounds.round(k, {}, false);  // the anchor's draw arrives
    if (k > 0) {
      var_x += variance(kProcessStdM);
      var_y += variance(kProcessStdM);
    }
    const double datum = 0.5 * (ranges[k][0] + ranges[k][1]);
    const double information = 1.0 / var_x + 2.0 / variance(kRangeStdM);
    mean = (mean / var_x + 2.0 / variance(kRangeStdM) * datum) / information;
    var_x = 1.0 / information;
    const Estimate e = rounds.estimate(1);
    ASSERT_TRUE(e.valid);
    EXPECT_NEAR(e.mean_m.x(), mean, 1e-9) << "step " << k;
    EXPECT_NEAR(e.mean_m.y(), 0.0, 1e-12);
    EXPECT_NEAR(e.covariance(0, 0), var_x, 1e-9) << "step " << k;
    EXPECT_NEAR(e.covariance(1, 1), var_y, 1e-9) << "step " << k;
    EXPECT_NEAR(e.covariance(0, 1), 0.0, 1e-12);
  }
}

// A beacon with noisy fixes ranging to a moving agent: it keeps to its fixes. Its range messages would all
// land on one position that does not move, where the agent's messages of every other window step come back
// to the agent; so its estimate is the average of its prior and its fixes, whatever the ranges say.
TEST(DmlTracking, ABeaconKeepsToItsFixes) {
  KalmanFilterParams params;
  params.process_noise_std_m = kProcessStdM;
  AgentSetup beacon_setup;
  beacon_setup.id = 0;
  beacon_setup.anchor = true;
  beacon_setup.initial_guess_m = Vec2(0.0, 0.0);
  beacon_setup.initial_guess_std_m = kGuessStdM;
  AgentSetup agent_setup = beacon_setup;
  agent_setup.id = 1;
  agent_setup.anchor = false;
  agent_setup.initial_guess_m = Vec2(10.0, 0.0);
  DmlTracking beacon(beacon_setup, params);
  DmlTracking agent(agent_setup, params);
  BeliefMessage from_beacon = *beacon.initial_outbox().belief;
  BeliefMessage from_agent = *agent.initial_outbox().belief;
  constexpr double kFixStdM = 1.0;
  const double fixes[][2] = {{0.8, -0.3}, {-0.2, 0.6}, {0.5, 0.1}, {0.9, -0.7}, {0.1, 0.4}};
  const double ranges[] = {12.0, 8.5, 11.7, 7.9, 12.4};  // far from the fixes' 10 m: they would pull
  double information = 1.0 / variance(kGuessStdM);
  Vec2 vector = Vec2::Zero();
  for (std::int64_t k = 0; k < 5; ++k) {
    MeasurementBatch beacon_batch;
    beacon_batch.world_step = k;
    beacon_batch.ranges.push_back({1, ranges[k], kRangeStdM});
    beacon_batch.fix =
        AbsoluteFix{Vec2(fixes[k][0], fixes[k][1]), variance(kFixStdM) * Mat2::Identity(), std::nullopt};
    MeasurementBatch agent_batch;
    agent_batch.world_step = k;
    agent_batch.ranges.push_back({0, ranges[k], kRangeStdM});
    for (int exchange = 0; exchange < 3; ++exchange) {
      Inbox to_beacon;
      to_beacon.beliefs.push_back({1, 0, from_agent});
      Inbox to_agent;
      to_agent.beliefs.push_back({0, 0, from_beacon});
      StepInput beacon_input;
      beacon_input.measurements = exchange == 0 ? &beacon_batch : nullptr;
      beacon_input.inbox = &to_beacon;
      StepInput agent_input;
      agent_input.measurements = exchange == 0 ? &agent_batch : nullptr;
      agent_input.inbox = &to_agent;
      from_beacon = *beacon.step(beacon_input).outbox.belief;
      from_agent = *agent.step(agent_input).outbox.belief;
    }
    information += 1.0 / variance(kFixStdM);
    vector += Vec2(fixes[k][0], fixes[k][1]) / variance(kFixStdM);
    const Estimate e = beacon.estimate();
    ASSERT_TRUE(e.valid);
    EXPECT_LT((e.mean_m - vector / information).norm(), 1e-9) << "step " << k;
    EXPECT_LT((e.covariance - Mat2::Identity() / information).norm(), 1e-9) << "step " << k;
  }
}

// Anchor — agent 1 — agent 2 on the x-axis, one world step iterated: belief propagation on this tree
// reaches the centralized covariance of (x1, x2). Without the cavity agent 2's information would come
// back to it through agent 1. The means keep the echo of each agent's own message in its neighbour's mean
// (docs/algorithms.md §9.8): 8e-5 m here, against posterior standard deviations of 0.3–0.4 m.
TEST(DmlTracking, ChainReachesTheCentralizedCovarianceWithTheCavity) {
  Rounds rounds({Vec2(0.0, 0.0), Vec2(10.0, 0.0), Vec2(20.0, 0.0)}, {true, false, false});
  const std::map<int, std::map<int, double>> draws{
      {0, {{1, 10.3}}}, {1, {{0, 9.9}, {2, 9.6}}}, {2, {{1, 10.2}}}};
  rounds.round(0, draws, true);
  for (int extra = 0; extra < 40; ++extra) rounds.round(0, {}, false);
  // Information form of (x1, x2): priors 1/σ0², the anchor edge on x1, the 1–2 edge on x2 − x1.
  const double p0 = 1.0 / variance(kGuessStdM);
  const double w = 2.0 / variance(kRangeStdM);
  Eigen::Matrix2d information;
  information << p0 + 2.0 * w, -w, -w, p0 + w;
  const Eigen::Vector2d vector(p0 * 10.0 + w * 0.5 * (10.3 + 9.9) - w * 0.5 * (9.6 + 10.2),
                               p0 * 20.0 + w * 0.5 * (9.6 + 10.2));
  const Eigen::Vector2d mean = information.ldlt().solve(vector);
  const Eigen::Matrix2d covariance = information.inverse();
  for (int i : {1, 2}) {
    const Estimate e = rounds.estimate(i);
    EXPECT_NEAR(e.mean_m.x(), mean(i - 1), 1e-3 * std::sqrt(covariance(i - 1, i - 1))) << "agent " << i;
    EXPECT_NEAR(e.covariance(0, 0), covariance(i - 1, i - 1), 1e-9) << "agent " << i;
    EXPECT_NEAR(e.covariance(1, 1), variance(kGuessStdM), 1e-9) << "agent " << i;
  }
}

/// The scalar Kalman filter and Rauch–Tung–Striebel smoother of a random walk along x, one datum per step
/// (information, information-weighted sum), from a prior N(mean, variance): the marginals of every step.
struct ScalarMarginals {
  std::vector<double> mean;
  std::vector<double> variance;
};
ScalarMarginals smoothed_walk(double mean, double var, const std::vector<std::pair<double, double>>& data) {
  const std::size_t n = data.size();
  std::vector<double> filtered_mean(n), filtered_var(n), predicted_var(n);
  for (std::size_t t = 0; t < n; ++t) {
    predicted_var[t] = t == 0 ? var : filtered_var[t - 1] + variance(kProcessStdM);
    const double predicted_mean = t == 0 ? mean : filtered_mean[t - 1];
    filtered_var[t] = 1.0 / (1.0 / predicted_var[t] + data[t].first);
    filtered_mean[t] = filtered_var[t] * (predicted_mean / predicted_var[t] + data[t].second);
  }
  ScalarMarginals out{filtered_mean, filtered_var};
  for (std::size_t t = n - 1; t-- > 0;) {
    const double gain = filtered_var[t] / predicted_var[t + 1];
    out.mean[t] = filtered_mean[t] + gain * (out.mean[t + 1] - filtered_mean[t]);
    out.variance[t] = filtered_var[t] + gain * gain * (out.variance[t + 1] - predicted_var[t + 1]);
  }
  return out;
}

/// The anchor's and the agent's draws of world step k (anchor at the origin, agent near x = 10).
double anchor_draw(std::int64_t k) { return 10.0 + 0.4 * std::sin(1.3 * static_cast<double>(k)); }
double agent_draw(std::int64_t k) { return 10.0 - 0.3 * std::cos(0.7 * static_cast<double>(k)); }

// One exchange per world step: the anchor's draw of step k reaches the agent at step k + 1 and joins the
// factor of step k, where it belongs. When the anchor's newer samples are lost, the held sample's draw is
// not counted again. The agent's x is then the Kalman filter of the draws that arrived, each at its step.
TEST(DmlTracking, ALateDrawJoinsItsOwnStepOnce) {
  Rounds rounds({Vec2(0.0, 0.0), Vec2(10.0, 0.0)}, {true, false});
  const double w = 1.0 / variance(kRangeStdM);
  std::vector<std::pair<double, double>> data;
  for (std::int64_t k = 0; k < 8; ++k) {
    rounds.round(k, {{0, {{1, anchor_draw(k)}}}, {1, {{0, agent_draw(k)}}}}, true);
    if (k == 1) rounds.hold(0);  // the anchor's sample of step 1 (its draw of step 1) is the last to arrive
    // The anchor's draw of step k − 1 arrives now (its draws of steps 2 on never do).
    if (k >= 1 && k - 1 <= 1) data.back() = {2.0 * w, w * (agent_draw(k - 1) + anchor_draw(k - 1))};
    data.emplace_back(w, w * agent_draw(k));
    if (k == 0) {
      // Step 0: the anchor's first sample is its start (not exact yet), its prior predicted by one step.
      const double far = variance(kGuessStdM) + variance(kProcessStdM);
      data.back().first = 1.0 / (1.0 / w + far);
      data.back().second = data.back().first * agent_draw(0);
    }
    const ScalarMarginals expected = smoothed_walk(10.0, variance(kGuessStdM), data);
    const Estimate e = rounds.estimate(1);
    EXPECT_NEAR(e.mean_m.x(), expected.mean.back(), 1e-9) << "step " << k;
    EXPECT_NEAR(e.covariance(0, 0), expected.variance.back(), 1e-9) << "step " << k;
  }
}

// Longer than the window, one exchange per step: the window's published marginals (its belief's window
// entries) are the Rauch–Tung–Striebel smoother of every draw, and the newest the Kalman filter's; the steps
// that left the window live on in its prior exactly (a tree: the chain and an exact anchor).
TEST(DmlTracking, TheWindowIsTheSmootherOfAllDraws) {
  Rounds rounds({Vec2(0.0, 0.0), Vec2(10.0, 0.0)}, {true, false});
  const double w = 1.0 / variance(kRangeStdM);
  const auto steps = static_cast<std::int64_t>(DmlTracking::kWindowSteps) + 4;
  std::vector<std::pair<double, double>> data;
  for (std::int64_t k = 0; k < steps; ++k) {
    rounds.round(k, {{0, {{1, anchor_draw(k)}}}, {1, {{0, agent_draw(k)}}}}, true);
    if (k >= 1) data.back() = {2.0 * w, w * (agent_draw(k - 1) + anchor_draw(k - 1))};
    data.emplace_back(w, w * agent_draw(k));
    if (k == 0) data.back() = {1.0 / (1.0 / w + variance(kGuessStdM) + variance(kProcessStdM)), 0.0};
    if (k == 0) data.back().second = data.back().first * agent_draw(0);
  }
  const ScalarMarginals expected = smoothed_walk(10.0, variance(kGuessStdM), data);
  const BeliefMessage& belief = rounds.belief(1);
  EXPECT_NEAR(belief.mean_m.x(), expected.mean.back(), 1e-9);
  int entries = 0;
  for (const auto& entry : belief.contributions) {
    if (entry.from < DmlTracking::kWindowEntryBase) continue;
    ++entries;
    const auto t = static_cast<std::size_t>(steps - 1 - (entry.from - DmlTracking::kWindowEntryBase));
    const Mat2 covariance = entry.information.inverse();
    EXPECT_NEAR(entry.info_vec.x(), expected.mean[t], 1e-9) << "step " << t;
    EXPECT_NEAR(covariance(0, 0), expected.variance[t], 1e-9) << "step " << t;
    EXPECT_NEAR(covariance(0, 1), 0.0, 1e-12);
  }
  EXPECT_EQ(entries, static_cast<int>(DmlTracking::kWindowSteps) - 1);
}

// Four agents in the plane (two anchors, a loop): every covariance stays symmetric and positive definite.
TEST(DmlTracking, CovariancesStaySymmetricPositiveDefiniteOnALoop) {
  const std::vector<Vec2> truth{Vec2(0.0, 0.0), Vec2(12.0, 0.0), Vec2(4.0, 8.0), Vec2(10.0, 9.0)};
  Rounds rounds({truth[0], truth[1], Vec2(5.0, 7.0), Vec2(9.0, 10.5)}, {true, true, false, false});
  const int pairs[][2] = {{0, 2}, {1, 2}, {1, 3}, {2, 3}, {0, 3}};
  for (std::int64_t k = 0; k < 20; ++k) {
    std::map<int, std::map<int, double>> draws;
    for (const auto& pair : pairs) {
      const double d =
          (truth[static_cast<std::size_t>(pair[0])] - truth[static_cast<std::size_t>(pair[1])]).norm();
      draws[pair[0]][pair[1]] = d + 0.3 * std::sin(1.7 * static_cast<double>(k + pair[1]));
      draws[pair[1]][pair[0]] = d - 0.2 * std::cos(0.9 * static_cast<double>(k + pair[0]));
    }
    rounds.round(k, draws, true);
    rounds.round(k, {}, false);
    for (int i : {2, 3}) {
      const Estimate e = rounds.estimate(i);
      ASSERT_TRUE(e.valid);
      EXPECT_EQ(e.covariance(0, 1), e.covariance(1, 0));
      EXPECT_GT(e.covariance.determinant(), 0.0);
      EXPECT_GT(e.covariance(0, 0), 0.0);
      EXPECT_LT((e.mean_m - truth[static_cast<std::size_t>(i)]).norm(), 1.0) << "agent " << i;
    }
  }
}

// The self-check (docs/algorithms.md §1.6): an agent whose draws fit its prediction and the anchor's position
// is not flagged; when its draws jump 4 m (8 σ) away from where its belief says it is, the window's residuals
// exceed the χ² quantile at once and it says so, and keeps saying so while the jump is in its window.
TEST(DmlTracking, DrawsItsBeliefCannotExplainAreFlagged) {
  Rounds rounds({Vec2(0.0, 0.0), Vec2(10.0, 0.0)}, {true, false});
  std::int64_t step = 0;
  auto world_step = [&](double range) {
    rounds.round(step, {{0, {{1, range}}}, {1, {{0, range}}}}, true);
    for (int extra = 0; extra < 2; ++extra) rounds.round(step, {}, false);
    ++step;
  };
  const double fitting[] = {10.2, 9.8, 10.1, 9.9, 10.3, 9.7, 10.0, 10.2, 9.9, 10.1, 9.8, 10.0};
  for (const double range : fitting) {
    world_step(range);
    EXPECT_FALSE(rounds.estimate(1).inconsistent) << "step " << step - 1 << ": draws that fit";
  }
  world_step(14.0);
  EXPECT_TRUE(rounds.estimate(1).inconsistent) << "a draw 8 sigma from the belief";
  EXPECT_FALSE(rounds.estimate(0).inconsistent) << "an anchor runs no check";
  for (int k = 0; k < 5; ++k) {
    world_step(14.0 + 0.1 * (k % 3 - 1));
    EXPECT_TRUE(rounds.estimate(1).inconsistent) << k + 1 << " steps after the jump";
  }
}

}  // namespace dml_tracking_test
}  // namespace swarmloc::estimators
