#pragma once
// The world model: ground truth, anchors, the communication graph and each agent's private start-up
// facts (anchor flag, initial guess, clock). Deterministic in the scenario seed, so the orchestrator,
// every agent process and the simulator build the same world independently.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/config/scenario_models.hpp"
#include "swarmloc/core/clock.hpp"
#include "swarmloc/estimators/consensus/joint_field.hpp"
#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/models/multipath.hpp"

namespace swarmloc::world {

/// A world that comes from data instead of the seeded generator: a --record file or a real dataset
/// (UTIAS MRCLAM). When World::recorded is set, advance_truth and generate_batch read it, so every
/// runtime (simulator, DDS orchestrator, fusion centre) replays the same steps unchanged.
class RecordedSteps {
 public:
  virtual ~RecordedSteps() = default;
  /// World steps available (0 … steps() − 1).
  [[nodiscard]] virtual std::int64_t steps() const = 0;
  /// True positions of every agent at world step `step`.
  [[nodiscard]] virtual std::vector<Vec2> truth(std::int64_t step) const = 0;
  /// Agent `agent`'s measurement batch of world step `step` (world_step = -1 if it has none).
  [[nodiscard]] virtual estimators::MeasurementBatch batch(AgentId agent, std::int64_t step) const = 0;
  /// True heading (rad) of agent `agent` at world step `step`: NaN when the data has none (a recording,
  /// or a gap in a dataset's groundtruth). Scores the pose estimators' 3-DOF NEES.
  [[nodiscard]] virtual double truth_heading(AgentId /*agent*/, std::int64_t /*step*/) const {
    return std::numeric_limits<double>::quiet_NaN();
  }
};

/// Thrown by a long computation whose WorkControl flag was set (Ctrl-C).
class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("interrupted") {}
};

/// Progress and cancellation of a run's long computations — building the world, creating the agents, the
/// simulation — which take minutes at 10^5 agents (a dense world: hours). Both members may be empty.
struct WorkControl {
  /// Polled in every long loop (each item, i.e. at least every few milliseconds); once it reads true the
  /// computation throws Cancelled (run_simulation instead returns the steps done, marked interrupted).
  /// Not owned: e.g. the flag a SIGINT handler sets.
  const std::atomic<bool>* cancel = nullptr;
  /// Called on the computing thread for a phase that has lasted a second, then at most four times a
  /// second: what it does ("world: neighbour graph, 31204 neighbours per agent so far") and the fraction
  /// done, in [0, 1].
  std::function<void(const std::string& phase, double fraction)> on_progress;

  [[nodiscard]] bool cancelled() const {
    return cancel != nullptr && cancel->load(std::memory_order_relaxed);
  }
  void throw_if_cancelled() const {
    if (cancelled()) throw Cancelled();
  }
};

/// One phase of a WorkControl'led computation: call tick() for every item of its loop.
class WorkPhase {
 public:
  WorkPhase(const WorkControl& control, std::string name)
      : control_(control), name_(std::move(name)), started_(std::chrono::steady_clock::now()) {}
  /// Throws Cancelled if the flag is set; reports done / total when due (a clock read: cheap enough for
  /// items of a microsecond).
  void tick(std::size_t done, std::size_t total) {
    control_.throw_if_cancelled();
    report(done, total);
  }
  /// Reports done / total when due, without looking at the flag.
  void report(std::size_t done, std::size_t total) {
    if (!control_.on_progress) return;
    const auto now = std::chrono::steady_clock::now();
    if (now - started_ < std::chrono::seconds(1) || now - last_ < std::chrono::milliseconds(250)) return;
    last_ = now;
    control_.on_progress(name_, total == 0 ? 1.0 : static_cast<double>(done) / static_cast<double>(total));
  }
  void rename(std::string name) { name_ = std::move(name); }
  /// A new phase in the same object: reported once it has lasted a second.
  void restart(std::string name) {
    name_ = std::move(name);
    started_ = std::chrono::steady_clock::now();
  }

 private:
  const WorkControl& control_;
  std::string name_;
  std::chrono::steady_clock::time_point started_;
  std::chrono::steady_clock::time_point last_{};
};

struct World {
  std::vector<Vec2> truth;  ///< current true positions (their planar part in a 3-D world)
  /// 2: a planar world; 3 (world.dimensions): every position has a z too, in `altitude`.
  int dimensions = 2;
  std::vector<double> altitude;          ///< 3-D: each agent's true z (empty in a planar world)
  std::vector<double> initial_altitude;  ///< 3-D: the z of each initial guess (anchors: the truth's)
  std::vector<bool> is_anchor;
  std::vector<std::vector<AgentId>> neighbours;  ///< communication graph at step 0 (sorted)
  std::vector<Vec2> initial_guess;               ///< prior each agent starts from (anchors: truth)
  double initial_guess_std_m = std::numeric_limits<double>::infinity();  ///< per axis; +inf: unknown
  /// The radius of the step-0 disk graph (`neighbours`); +inf: not one.
  double comm_radius_m = std::numeric_limits<double>::infinity();
  std::vector<core::ClockModel> clocks;
  std::vector<models::Wall> walls;  ///< reflecting walls (multipath measurements only)
  int placement_attempts = 1;       ///< draws needed to satisfy world.require_connected
  /// Monte Carlo trial: the configuration (placement, anchors, graph, clocks) depends on the seed
  /// only; initial guesses, measurement noise, motion noise and link loss also depend on the trial.
  std::uint64_t trial = 0;
  std::vector<double> initial_heading;            ///< pose-state algorithms (empty: all 0)
  std::shared_ptr<const RecordedSteps> recorded;  ///< set: truth and batches come from data
  /// The true state of the target the agents estimate (algorithm dle): position, then velocity for a
  /// moving target. Empty: the agents estimate their own positions.
  VecX target;
  /// The true static field (algorithm joint_field): one value per cell of field_sensor(scenario).grid.
  VecX field;

  [[nodiscard]] int size() const { return static_cast<int>(truth.size()); }
  [[nodiscard]] bool estimates_target() const { return target.size() > 0; }
  /// What agent `id`'s estimate is scored against: its own true position, or the target's.
  [[nodiscard]] Vec2 scored_truth(AgentId id) const;
  /// The z of scored_truth in a 3-D world (0 in a planar one).
  [[nodiscard]] double scored_truth_z(AgentId id) const;
  /// Whether agent `id` is scored: anchors know their position, but every sensor estimates a target.
  [[nodiscard]] bool scored(AgentId id) const;
  [[nodiscard]] int anchor_count() const;
  [[nodiscard]] double mean_degree() const;
  [[nodiscard]] estimators::AgentSetup setup_of(AgentId id) const;
  /// Agent `id`'s true position with its z (0 in a planar world).
  [[nodiscard]] Vec3 position3(AgentId id) const;
  /// The true distance between agents `a` and `b`: planar, or in space in a 3-D world.
  [[nodiscard]] double distance(AgentId a, AgentId b) const;
};

/// Builds the world of `scenario` (placement, anchors, graph, initial guesses, clocks).
/// Throws config::ScenarioError if the positions file is unreadable or no connected placement is
/// found within 1000 draws.
///
/// `accepted_draw` ≥ 0: the draw an earlier build_world of the same scenario accepted
/// (World::placement_attempts − 1), taken without re-running the localizability check — a dense
/// 2n × 2n factorization that made up about half of an agent's start-up CPU at N = 500. The cheap
/// connectivity check still runs; a draw that fails it throws config::ScenarioError.
///
/// `control`: progress of the long phases (draws, neighbour graph, connectivity check) and the
/// cancellation flag, polled per agent; a set flag throws Cancelled. The world does not depend on it.
World build_world(const config::Scenario& scenario, std::uint64_t trial = 0, int accepted_draw = -1,
                  const WorkControl& control = {});

/// Attaches recorded steps to `world` (World::recorded) and takes its truth of step 0. Throws
/// std::invalid_argument if the recording's agent count differs or it holds no step.
void attach_recorded(World& world, std::shared_ptr<const RecordedSteps> recorded);

/// Moves the truth one world step (random walk when world.motion = random_walk) and the target (double
/// integrator). Seeded by (seed, step). A recorded world takes its agents' truth from the recording; its
/// target, a function of the scenario seed, moves as generated.
void advance_truth(World& world, const config::Scenario& scenario, std::int64_t step);

/// What the world measures for an algorithm: its registry entry's kinds (config/algorithms.hpp).
using MeasurementKinds = config::MeasurementKinds;
MeasurementKinds measurement_kinds(const std::string& algorithm);

// target_model and field_sensor: config/scenario_models.hpp (an agent needs them too).

/// y = σ L ξ with L Lᵀ = C, C_kl = exp(−‖c_k − c_l‖² / (2ℓ²)) over the cell centres (a discrete Gaussian
/// random field; ξ standard normal from `rng`).
VecX draw_gaussian_field(const estimators::consensus::FieldGrid& grid, double std_dev, double correlation_m,
                         std::mt19937_64& rng);

/// The walls of scenario.world (wall_count lines outside the area, docs/algorithms.md §5.4).
std::vector<models::Wall> make_walls(const config::Scenario& scenario);

/// Agent `agent`'s noisy measurements for world step `step`, of the kinds its algorithm consumes:
/// - ranges to each current neighbour, drawn per endpoint ([B-1]) or shared by both ends
///   (noise.shared_range_draws), additive or proportional to the distance (Calafiore et al. eq. (16));
/// - for anchors (Kalman family), an absolute fix;
/// - relative positions s_ij = x_j − x_i + ε, one draw per link shared by both ends (i gets s_ij, j gets
///   −s_ij, [C-7]);
/// - one reflected path per wall with both ends on its side: a length draw shared by both ends and an
///   independent angle-of-arrival error at each end (docs/algorithms.md §5.4);
/// - a reading of the target (target 0) if the sensor is within world.target_sensing_radius_m of it:
///   its position + N(0, target_std² I) (kind 0), or range + N(0, target_std²) and bearing +
///   N(0, target_bearing_std²) from the sensor (kind 1);
/// - a reading of the field, h(x)ᵀ y + N(0, field_std²) at the sensor's true position x (kind
///   kFieldReading: value(0) = the reading, covariance(0, 0) = its variance).
/// With noise.draw = once every step repeats step 0's draws (a static snapshot).
estimators::MeasurementBatch generate_batch(const World& world, const config::Scenario& scenario,
                                            AgentId agent, std::int64_t step);

/// The world time reported for step `step` (metrics, TUM trajectories): step / run.rate_hz, or for a
/// dataset world (world.source = mrclam) the dataset seconds since its start, step · world.data_step_s.
double reported_time_s(const config::Scenario& scenario, std::int64_t step);

/// The seed of trial `trial`'s random streams (trial 0 uses the scenario seed itself).
std::uint64_t trial_seed(std::uint64_t seed, std::uint64_t trial);

/// The physical-plausibility bound used to reject absurd samples: positions beyond this from the
/// area's centre are rejected.
double absurd_position_bound_m(const config::Scenario& scenario);

}  // namespace swarmloc::world
