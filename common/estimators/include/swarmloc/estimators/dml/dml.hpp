#pragma once
// Distributed maximum likelihood at one agent (docs/algorithms.md §9): sufficient statistics of every
// range draw, a nonlinear block-Jacobi solve toward the network's ML position, Gaussian belief
// propagation for its covariance, a multilateration start from anchors outward and a residual self-check.
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <string_view>
#include <vector>

#include "swarmloc/estimators/dml/connectivity.hpp"
#include "swarmloc/estimators/dml/local_map.hpp"
#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/kalman/params.hpp"

namespace swarmloc::estimators {

/// One agent of `dml`. Each step it (1) adds the step's ranges to per-neighbour sums and takes the
/// neighbours' summaries of their own draws of the same edges, (2) once localized, solves its own
/// position with the neighbours' published means held fixed (the fixed point of all agents doing this is
/// a stationary point of the whole network's likelihood, whatever the message timing), (3) updates its
/// information matrix from rank-one belief-propagation messages with the cavity taken out, and (4) tests
/// its residuals and the graph (negative connectivity: it is farther than the radius from every agent it
/// does not hear). Before it is localized it waits for three localized neighbours with a spread geometry
/// and multilaterates; with two, the graph picks the mirror member when it can, and the starting guess is
/// used only if neither decides.
class Dml final : public Estimator {
 public:
  Dml(const AgentSetup& setup, const KalmanFilterParams& params);

  [[nodiscard]] std::string_view name() const override { return "dml"; }
  [[nodiscard]] Outbox initial_outbox() const override;
  StepOutput step(const StepInput& input) override;
  [[nodiscard]] Estimate estimate() const override;

  /// Steps without a multilateration after which an agent starts from its initial guess instead.
  static constexpr std::int64_t kInitializationPatienceSteps = 50;
  /// Edge summaries carried per state message (each edge's turn comes every degree / this steps).
  static constexpr std::size_t kSummariesPerMessage = 2;

 private:
  struct Edge {
    double own_information = 0.0;     // Σ 1/σ² of this agent's draws
    double own_weighted_range = 0.0;  // Σ r/σ²
    double last_range_m = 0.0;
    double peer_information = 0.0;  // the neighbour's summary of its draws of the edge
    double peer_mean_range_m = 0.0;
    bool has_state = false;
    StateMessage state;          // the neighbour's newest state
    double message_scale = 0.0;  // m_{j→i} = s·aaᵀ, the BP message last added to the belief
    double sent_scale = 0.0;     // m_{i→j}, the message this agent's belief sends the neighbour
    [[nodiscard]] double information() const { return own_information + peer_information; }
    [[nodiscard]] double mean_range_m() const;
    [[nodiscard]] bool usable() const;
  };
  struct Reference {  // a localized neighbour as a multilateration or solve term
    AgentId id;
    Vec2 position_m;
    double mean_range_m;
    double information;
  };

  void absorb_measurements(const MeasurementBatch& batch);
  void absorb_states(const Inbox& inbox);
  [[nodiscard]] std::vector<Reference> references() const;
  [[nodiscard]] double local_cost(const Vec2& x, const std::vector<Reference>& refs) const;
  [[nodiscard]] Vec2 solve_position(Vec2 x, const std::vector<Reference>& refs) const;
  [[nodiscard]] std::optional<Vec2> multilaterate(const std::vector<Reference>& refs) const;
  struct GuessedStart {
    Vec2 position_m;
    bool ambiguous;  // the ranges left a mirror pair or a circle, and neither the guess nor the graph could
                     // tell
    std::optional<std::pair<AgentId, AgentId>> hinge;  // a mirror pair: the two references
  };
  [[nodiscard]] double penetration(const Vec2& x) const;
  /// How far `x` contradicts the graph or the ranges through a neighbour (> margin: impossible).
  [[nodiscard]] double impossibility(const Vec2& x) const;
  /// Of two places (a mirror pair), the one the graph allows when it rules the other out (0: first, 1:
  /// second); nothing when it decides neither.
  [[nodiscard]] std::optional<int> allowed_by_graph(const Vec2& first, const Vec2& second) const;
  [[nodiscard]] std::optional<Vec2> mirror_of_current() const;
  void check_mirror();
  [[nodiscard]] std::optional<GuessedStart> start_from_guess(const std::vector<Reference>& refs) const;
  struct LocalMap {  // the agent (node 0), its neighbours, the agents they relay, and the ranges among them
    std::vector<local_map::Node> nodes;
    std::vector<local_map::Range> ranges;
    double shortest_range_m = std::numeric_limits<double>::infinity();  // of this agent's own
  };
  /// beliefs_only: hold only neighbours that publish a covariance (the others are placed), and leave out
  /// neighbours not localized.
  [[nodiscard]] LocalMap draw_local_map(bool beliefs_only) const;
  [[nodiscard]] std::optional<local_map::Placement> place_in_local_map() const;
  /// This agent's covariance in its local map linearized at the current means (docs/algorithms.md §9.3).
  [[nodiscard]] std::optional<Mat2> map_covariance() const;
  struct MapStart {
    Vec2 position_m;
    bool
        decided;  // false: a mirror image fits too and the graph cannot rule it out (the nearer to the guess)
  };
  [[nodiscard]] std::optional<MapStart> start_from_local_map() const;
  /// Localizes the agent if it can: multilateration, a start the guess or the graph decides, its local map,
  /// and last an ambiguous start from the guess.
  void start(const std::vector<Reference>& refs);
  void update_information();
  [[nodiscard]] std::optional<Mat2> region_covariance() const;
  [[nodiscard]] double residual_statistic(int& degrees_of_freedom) const;
  [[nodiscard]] bool leans_on_flagged_neighbours(const std::vector<Reference>& refs) const;
  [[nodiscard]] bool exact_anchor() const;
  [[nodiscard]] StateMessage state_message() const;
  [[nodiscard]] Outbox published();

  AgentSetup setup_;
  std::map<AgentId, Edge> edges_;
  Vec2 x_;
  Mat2 information_ = Mat2::Zero();          // the belief propagation belief (published)
  std::optional<Mat2> reported_covariance_;  // the estimate's: docs/algorithms.md §9.3, region correction
  Mat2 fix_information_ = Mat2::Zero();      // Σ C⁻¹ of the fixes (anchors with noisy fixes)
  Vec2 fix_information_vector_ = Vec2::Zero();
  bool localized_ = false;
  bool inconsistent_ = false;
  bool doubtful_support_ = false;  // a flagged neighbour, and too few unflagged ones to fix the position
  bool ambiguous_start_ = false;   // flagged until the graph confirms it: range-only data cannot
  std::optional<std::pair<AgentId, AgentId>> hinge_;  // the mirror line of a start from two references
  TwoHopPositions two_hop_;
  RelayedRanges relays_;
  std::int64_t steps_ = 0;
  std::size_t summary_cursor_ = 0;
};

}  // namespace swarmloc::estimators
