#pragma once
// Distributed maximum likelihood at one agent (docs/algorithms.md §9): sufficient statistics of every
// range draw, a nonlinear block-Jacobi solve toward the network's ML position, Gaussian belief
// propagation for its covariance, a multilateration start from anchors outward and a residual self-check.
#include <array>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <string_view>
#include <vector>

#include "swarmloc/estimators/dml/connectivity.hpp"
#include "swarmloc/estimators/dml/dimension.hpp"
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
/// does not hear). Before it is localized it waits for D + 1 localized neighbours with a spread geometry
/// and multilaterates; with D, the graph picks the mirror member when it can, and the starting guess is
/// used only if neither decides. D is the dimension of the positions, 2 or 3 (docs/algorithms.md §9.9).
template <int D>
class DmlT final : public Estimator {
 public:
  static_assert(D == 2 || D == 3);
  using Vec = VecD<D>;
  using Mat = MatD<D>;
  /// The references a start from exactly D of them rests on: its mirror is across their line (plane).
  using Hinge = std::array<AgentId, static_cast<std::size_t>(D)>;

  DmlT(const AgentSetup& setup, const KalmanFilterParams& params);

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
    // What this agent keeps of the neighbour's newest state besides its position and its summaries.
    bool active = false;
    bool anchor = false;
    bool inconsistent = false;
    std::uint16_t degree = 0;
    bool has_position = false;  // its state holds a position in D (3-D: an altitude)
    Vec mean_m = Vec::Zero();   // its published position and covariance, in D
    Mat covariance = Mat::Zero();
    double message_scale = 0.0;  // m_{j→i} = s·aaᵀ, the BP message last added to the belief
    double sent_scale = 0.0;     // m_{i→j}, the message this agent's belief sends the neighbour
    // The neighbour's belief without this agent's message, as the neighbour published it: its mean as an
    // offset from mean_m, and its variance along the edge (docs/algorithms.md §9.2).
    struct Cavity {
      Vec offset_m = Vec::Zero();
      double variance_m2 = 0.0;
    };
    std::optional<Cavity> cavity;
    [[nodiscard]] double information() const { return own_information + peer_information; }
    [[nodiscard]] double mean_range_m() const;
    [[nodiscard]] bool usable() const;
  };
  struct Reference {  // a localized neighbour as a multilateration or solve term
    AgentId id;
    Vec position_m;
    double mean_range_m;
    double information;
  };

  void absorb_measurements(const MeasurementBatch& batch);
  void absorb_states(const Inbox& inbox);
  [[nodiscard]] std::vector<Reference> references() const;
  [[nodiscard]] double local_cost(const Vec& x, const std::vector<Reference>& refs) const;
  [[nodiscard]] Vec solve_position(Vec x, const std::vector<Reference>& refs) const;
  /// The neighbours as belief propagation's messages to this agent: each one's cavity mean, weighed by its
  /// message's scale (docs/algorithms.md §9.2).
  [[nodiscard]] std::vector<Reference> message_references() const;
  /// For each neighbour whose message the belief holds, the belief without it (published).
  [[nodiscard]] std::vector<EdgeCavity> cavities() const;
  [[nodiscard]] std::optional<Vec> multilaterate(const std::vector<Reference>& refs) const;
  /// Σ ν²/(1/W + aᵀP_j a) over the references at x: how well x fits them, the neighbours' covariances in.
  [[nodiscard]] double fit_statistic(const Vec& x, const std::vector<Reference>& refs) const;
  /// 3-D: a multilateration's solution, its mirror image across the references' plane if that fits clearly
  /// better, or the one the graph or the guess picks when both fit; nothing if none of them decides
  /// (docs/algorithms.md §9.9).
  [[nodiscard]] std::optional<Vec> unless_mirrored(const Vec& solution,
                                                   const std::vector<Reference>& refs) const;
  struct GuessedStart {
    Vec position_m;
    bool ambiguous;  // the ranges left a mirror pair or a continuum (circle, sphere), and neither the guess
                     // nor the graph could tell
    std::optional<Hinge> hinge;  // a mirror pair: the D references
  };
  /// The point of the continuum fewer than D references leave (2-D: a circle; 3-D: a sphere or a circle)
  /// nearest the current position.
  [[nodiscard]] Vec on_continuum_nearest(const std::vector<Reference>& refs) const;
  struct MirrorPair {
    Vec left;
    Vec right;
    double across;  // each one's distance from the references' line (plane)
    Hinge hinge;
  };
  /// The mirror pair the first D references leave; nothing if there are fewer or they do not span a line
  /// (plane).
  [[nodiscard]] std::optional<MirrorPair> mirror_pair(const std::vector<Reference>& refs) const;
  [[nodiscard]] double penetration(const Vec& x) const;
  /// How far `x` contradicts the graph or the ranges through a neighbour (> margin: impossible).
  [[nodiscard]] double impossibility(const Vec& x) const;
  /// Of two places (a mirror pair), the one the graph allows when it rules the other out (0: first, 1:
  /// second); nothing when it decides neither.
  [[nodiscard]] std::optional<int> allowed_by_graph(const Vec& first, const Vec& second) const;
  [[nodiscard]] std::optional<Vec> mirror_of_current() const;
  void check_mirror();
  [[nodiscard]] std::optional<GuessedStart> start_from_guess(const std::vector<Reference>& refs) const;
  struct LocalMap {  // the agent (node 0), its neighbours, the agents they relay, and the ranges among them
    std::vector<local_map::NodeT<D>> nodes;
    std::vector<local_map::Range> ranges;
    double shortest_range_m = std::numeric_limits<double>::infinity();  // of this agent's own
  };
  /// beliefs_only: hold only neighbours that publish a covariance (the others are placed), and leave out
  /// neighbours not localized.
  [[nodiscard]] LocalMap draw_local_map(bool beliefs_only) const;
  /// refs: 3-D, their mirror pair seeds the map too.
  [[nodiscard]] std::optional<local_map::PlacementT<D>> place_in_local_map(
      const std::vector<Reference>& refs) const;
  /// This agent's covariance in its local map linearized at the current means (docs/algorithms.md §9.3).
  [[nodiscard]] std::optional<Mat> map_covariance() const;
  struct MapStart {
    Vec position_m;
    bool
        decided;  // false: a mirror image fits too and the graph cannot rule it out (the nearer to the guess)
  };
  [[nodiscard]] std::optional<MapStart> start_from_local_map(const std::vector<Reference>& refs) const;
  /// Localizes the agent if it can: multilateration, a start the guess or the graph decides, its local map,
  /// and last an ambiguous start from the guess.
  void start(const std::vector<Reference>& refs);
  void update_information();
  [[nodiscard]] std::optional<Mat> region_covariance() const;
  [[nodiscard]] double residual_statistic(int& degrees_of_freedom) const;
  [[nodiscard]] bool leans_on_flagged_neighbours(const std::vector<Reference>& refs) const;
  [[nodiscard]] bool exact_anchor() const;
  /// The covariance it publishes: zero (exact anchor), its belief's, or the undefined one.
  [[nodiscard]] Mat published_covariance() const;
  [[nodiscard]] StateMessage state_message() const;
  [[nodiscard]] Outbox published();

  AgentSetup setup_;
  std::map<AgentId, Edge> edges_;
  Vec x_;
  Mat information_ = Mat::Zero();           // the belief propagation belief (published)
  std::optional<Mat> reported_covariance_;  // the estimate's: docs/algorithms.md §9.3, region correction
  Mat fix_information_ = Mat::Zero();  // Σ C⁻¹ of the fixes (anchors with noisy fixes; planar in 3-D)
  Vec fix_information_vector_ = Vec::Zero();
  bool localized_ = false;
  bool inconsistent_ = false;
  bool doubtful_support_ = false;  // a flagged neighbour, and too few unflagged ones to fix the position
  bool ambiguous_start_ = false;   // flagged until the graph confirms it: range-only data cannot
  std::optional<Hinge> hinge_;     // the mirror line (plane) of a start from D references
  TwoHopPositionsT<D> two_hop_;
  RelayedRangesT<D> relays_;
  std::int64_t steps_ = 0;
  std::size_t summary_cursor_ = 0;
};

extern template class DmlT<2>;
extern template class DmlT<3>;
using Dml = DmlT<2>;

}  // namespace swarmloc::estimators
