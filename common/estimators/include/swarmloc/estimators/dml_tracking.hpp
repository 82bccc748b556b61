#pragma once
// Distributed tracking at one agent (`dml_track`, docs/algorithms.md §9.8): per world step, Gaussian belief
// propagation on the linearized factor graph of the current positions. Unary factor: the agent's own
// predicted belief (last step's marginal + the random walk's Q) and, for a beacon, this step's fix; one
// range factor per edge and step holding both ends' draws of that step; rank-one messages with the cavity
// taken out, relinearized every iteration. Several agent steps per world step iterate it.
#include <cstdint>
#include <map>
#include <string_view>

#include "swarmloc/estimators/estimator.hpp"

namespace swarmloc::estimators {

class DmlTracking final : public Estimator {
 public:
  DmlTracking(const AgentSetup& setup, const KalmanFamilyParams& params);

  [[nodiscard]] std::string_view name() const override { return "dml_track"; }
  [[nodiscard]] Outbox initial_outbox() const override;
  StepOutput step(const StepInput& input) override;
  [[nodiscard]] Estimate estimate() const override;

  /// Relinearizations per agent step with the neighbours' beliefs held (the agent's own part of BP).
  static constexpr int kLocalIterations = 3;

 private:
  /// A rank-one Gaussian message s·aaᵀ (information), s·z·a (information vector): aᵀx ~ N(z, 1/s).
  struct RankOne {
    double scale = 0.0;
    double mean = 0.0;
    Vec2 direction = Vec2::Zero();
  };
  struct Factor {  // the edge's linearized datum this step: aᵀ(x_i − x_j) ~ N(range, 1/information)
    double information = 0.0;
    double range_m = 0.0;
  };
  struct Edge {
    double own_information = 0.0;  // this world step's own draw: 1/σ² (0: none)
    double own_range_m = 0.0;
    bool has_belief = false;
    std::int64_t tag = -1;  // the world step the neighbour's belief and draw belong to
    Vec2 mean_m = Vec2::Zero();
    Mat2 covariance = Mat2::Zero();  // zero: an exactly known anchor
    double peer_information = 0.0;   // the neighbour's draw of step `tag`
    double peer_range_m = 0.0;
    std::int64_t peer_draw_used = -1;       // newest step whose peer draw entered a finished step's factor
    std::int64_t peer_draw_in_factor = -1;  // the step of the peer draw in the current factor (−1: none)
    RankOne incoming;                       // m_{f→i}: the factor's message in this agent's belief
    Factor factor;                          // the datum of the current step's factor
  };

  void start_world_step(const MeasurementBatch& batch);
  void absorb_beliefs(const Inbox& inbox);
  [[nodiscard]] Factor factor_of(Edge& edge) const;
  [[nodiscard]] RankOne message_to_self(Edge& edge) const;
  [[nodiscard]] RankOne message_to_peer(const Edge& edge, const Vec2& a) const;
  void update_belief();
  [[nodiscard]] bool exact_anchor() const;
  [[nodiscard]] BeliefMessage belief_message() const;

  AgentSetup setup_;
  double process_variance_m2_ = 0.0;         // per world step and axis; 0 for a beacon (it does not move)
  double params_process_variance_m2_ = 0.0;  // the random walk of a moving agent (a neighbour's)
  bool noisy_fix_ = false;                   // a beacon that has received a fix with a covariance
  std::int64_t world_step_ = -1;             // the step being estimated (−1: before the first batch)
  Vec2 prior_mean_;
  Mat2 prior_information_ = Mat2::Zero();
  Mat2 fix_information_ = Mat2::Zero();  // this step's fix (a beacon with a noisy fix)
  Vec2 fix_information_vector_ = Vec2::Zero();
  Vec2 mean_;
  Mat2 information_ = Mat2::Zero();
  std::map<AgentId, Edge> edges_;
};

}  // namespace swarmloc::estimators
