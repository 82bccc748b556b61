#pragma once
// Distributed tracking at one agent (`dml_track`, docs/algorithms.md §9.8): Gaussian belief propagation on
// the space-time factor graph of a sliding window. The agent keeps its last kWindowSteps positions as a
// chain (random-walk motion factors, the prior of the steps that left the window, a beacon's fixes) and one
// rank-one range factor per edge and window step holding both ends' draws of that step; the chain is solved
// exactly (forward filter, backward smoother) given the range messages, which take the neighbour's published
// marginal of the same step (its variance with the cavity out, its mean as it is) and are relinearized every
// iteration.
#include <cstdint>
#include <deque>
#include <map>
#include <string_view>

#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/kalman/params.hpp"
#include "swarmloc/estimators/self_check.hpp"

namespace swarmloc::estimators {

class DmlTracking final : public Estimator {
 public:
  DmlTracking(const AgentSetup& setup, const KalmanFilterParams& params);

  [[nodiscard]] std::string_view name() const override { return "dml_track"; }
  [[nodiscard]] Outbox initial_outbox() const override;
  StepOutput step(const StepInput& input) override;
  [[nodiscard]] Estimate estimate() const override;

  /// Relinearizations per agent step with the neighbours' beliefs held (the agent's own part of BP).
  static constexpr int kLocalIterations = 3;
  /// World steps in the window (the newest included).
  static constexpr std::size_t kWindowSteps = 16;
  /// A belief contribution whose `from` is kWindowEntryBase + age carries the sender's marginal of the
  /// window step `age` steps before the belief's own: info_vec holds the mean, information the information.
  static constexpr AgentId kWindowEntryBase = AgentId{1} << 30;

 private:
  /// A rank-one Gaussian message s·aaᵀ (information), s·z·a (information vector): aᵀx ~ N(z, 1/s).
  struct RankOne {
    double scale = 0.0;
    double mean = 0.0;
    Vec2 direction = Vec2::Zero();
  };
  struct Factor {  // the edge's linearized datum at one step: aᵀ(x_i − x_j) ~ N(range, 1/information)
    double information = 0.0;
    double range_m = 0.0;
  };
  struct SlotEdge {                // one edge at one window step
    double own_information = 0.0;  // this agent's draw of the step: 1/σ² (0: none)
    double own_range_m = 0.0;
    double peer_information = 0.0;  // the neighbour's draw of the step (0: not received)
    double peer_range_m = 0.0;
    RankOne incoming;  // m_{f→i}: the factor's message in this agent's marginal of the step
  };
  struct Slot {  // one world step of the window
    std::int64_t world_step = 0;
    Mat2 fix_information = Mat2::Zero();  // a beacon's noisy fix of the step
    Vec2 fix_information_vector = Vec2::Zero();
    Vec2 mean_m = Vec2::Zero();  // the marginal (smoothed) belief
    Mat2 covariance = Mat2::Zero();
    Mat2 information = Mat2::Zero();
    Vec2 predicted_mean_m = Vec2::Zero();  // the forward filter's prediction of this step (no data of it)
    Mat2 predicted_covariance = Mat2::Zero();
    std::map<AgentId, SlotEdge> edges;
  };
  struct PeerMarginal {
    Vec2 mean_m = Vec2::Zero();
    Mat2 covariance = Mat2::Zero();  // zero: an exactly known anchor
  };
  struct Peer {  // the neighbour's newest belief sample
    bool has_belief = false;
    bool exact = false;
    std::int64_t tag = -1;                        // the world step of its newest marginal
    std::map<std::int64_t, PeerMarginal> window;  // world step → its marginal
  };

  void start_world_step(const MeasurementBatch& batch);
  /// The self-check's residuals of a new step's own draws (docs/algorithms.md §1.6), against this agent's
  /// prediction of the step and each neighbour's newest belief predicted to it.
  void check_ranges(const MeasurementBatch& batch, const Slot& slot);
  void absorb_beliefs(const Inbox& inbox);
  [[nodiscard]] Factor factor_of(const SlotEdge& edge) const;
  [[nodiscard]] RankOne message_to_self(const Slot& slot, const SlotEdge& edge, const Peer& peer) const;
  [[nodiscard]] static double scale_to_peer(const Slot& slot, const SlotEdge& edge, const Factor& factor,
                                            const Vec2& a);
  void update_window();
  void solve_chain();
  [[nodiscard]] bool exact_anchor() const;
  [[nodiscard]] BeliefMessage belief_message() const;

  AgentSetup setup_;
  double process_variance_m2_ = 0.0;         // per world step and axis; 0 for a beacon (it does not move)
  double params_process_variance_m2_ = 0.0;  // the random walk of a moving agent (a neighbour's)
  bool noisy_fix_ = false;                   // a beacon that has received a fix with a covariance
  std::int64_t world_step_ = -1;             // the newest step (−1: before the first batch)
  Vec2 tail_mean_;                           // the prior of the oldest window step: what left the window
  Mat2 tail_information_ = Mat2::Zero();
  std::deque<Slot> window_;
  std::map<AgentId, Peer> peers_;
  RangeResidualCheck self_check_;
};

}  // namespace swarmloc::estimators
