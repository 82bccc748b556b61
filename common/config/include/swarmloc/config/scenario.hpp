#pragma once
// The validated scenario (docs/design.md §6). config/ is the only place that knows the YAML format; every
// other layer consumes these structs. Defaults live here, in-class, and are documented in
// docs/scenario.md key by key.
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "swarmloc/core/types.hpp"

namespace swarmloc::config {

/// Thrown for any invalid scenario or override; what() names the key path, e.g.
/// "network.loss: 1.4 is outside [0, 1]". Maps to exit code 2.
class ScenarioError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

enum class Placement { kUniform, kGrid, kFile };
/// Where the world comes from: the seeded generator, or a real dataset (UTIAS MRCLAM, docs/real-data.md).
enum class WorldSource { kGenerated, kMrclam };
enum class Motion { kStatic, kRandomWalk };
/// The target of algorithm dle (Atanasov et al. Sec. II): still, or a double integrator driven by white
/// acceleration.
enum class TargetMotion { kStatic, kDoubleIntegrator };
/// What a sensor reads of the target: its position plus noise (H = [I 0]), or range and bearing from the
/// sensor (Atanasov et al. eq. (4)).
enum class TargetSensing { kLinear, kRangeBearing };
/// How a sensor reads the field of algorithm joint_field (Atanasov et al. Fig. 5): tents around the cell
/// centres, continuous in its position, or the value of the cell it is in, which jumps at cell boundaries.
enum class FieldSensing { kContinuous, kCellBased };
enum class RunMode { kFreeRun, kLockstep };
/// How `swarmloc sim` drives the agents: synchronous rounds, or each agent on its own clock over a
/// network with delay (discrete events on virtual time, docs/architecture.md "Simulator").
enum class SimClock { kRounds, kAgents };
/// Where each agent's free-run timer fires within its period: spread over the agents (as deployed, so
/// they do not all publish at once) or at the same instant for every agent.
enum class TickPhase { kSpread, kAligned };
enum class InitialGuess { kNoisyTruth, kUniform };
/// local_bb's ΔD_i in Calafiore et al. eq. (15): the change of D_i(p) between updates, neighbours' moves
/// included (docs/algorithms.md [E-6]), or the change node i's own move made at the neighbours' newest
/// positions (the equation as printed).
enum class LocalBbDifference { kGradientChange, kOwnMove };
/// multipath_bp: each path's variance is σ² alone (Leng et al.), or σ² plus what its angle-of-arrival errors
/// do to eq. (1) (not in Leng et al.; estimators::bp::path_variances).
enum class PathVariance { kRangeOnly, kWithDoa };
/// multipath_bp: nodes exchange full beliefs (Leng et al. as printed, [D-4]), or exact GaBP's cavity messages
/// (not in Leng et al.; estimators::bp::MultipathBpParams::exact_messages).
enum class BpMessages { kBeliefs, kExact };
enum class Reliability { kBestEffort, kReliable };
enum class Durability { kVolatile, kTransientLocal };
/// Range noise: additive N(0, range_std²), proportional N(0, (range_factor·d)²) (Calafiore et al. eq.
/// (16)), or affine N(0, (range_std + range_factor·d)²) (a camera's range error, docs/real-data.md).
enum class RangeNoise { kAdditive, kProportional, kAffine };
/// Measurement noise drawn anew every world step, or once per run (a static snapshot, as in Leng et al. and
/// Calafiore et al.).
enum class NoiseDraw { kPerStep, kOnce };

struct QosSettings {
  Reliability reliability = Reliability::kBestEffort;
  int history_depth = 1;
  Durability durability = Durability::kVolatile;
  double deadline_s = 0.0;          ///< 0 = infinite
  double liveliness_lease_s = 0.0;  ///< 0 = infinite
};

// The algorithm's parameter blocks. Member names are the flat key names (algorithm.<member>), so a key
// cannot drift from its member; which algorithms read a block is the registry's (algorithms.hpp).

/// The filters' prior, process noise and update rules: the Kalman (ieif, iekf) and pose families, the
/// fusion centre (process noise and prior std) and dle (prior information).
struct KalmanParams {
  double process_noise_std_m = 0.01;
  double initial_information = 1e-6;
  double initial_std_m = 8.66;
  bool inflate_stale = true;
  double range_gate_chi2 = 0.0;  ///< chi-square gate on range innovations (ieif, iekf); 0 = off
  /// ieif, iekf: Gauss–Newton passes per update; 1 = Gasparri & Pascucci as printed
  int update_iterations = 1;
};

/// The pose-state family (pose_ekf, pose_ieif, dead_reckoning), beside the Kalman block.
struct PoseParams {
  double initial_heading_std_rad = 0.1;  ///< heading prior std
  double range_bearing_gate_chi2 = 0.0;  ///< 2-dof gate; 0 = off
  int team_share_spans = 50;             ///< team_pose_ekf: spans each sample repeats, [1, 64]
  int team_wait_steps = 50;              ///< team_pose_ekf: world steps the settled filter waits for a member
};

/// The distributed gradient family (dgbb, local_bb, fixed_step, step_length; docs/algorithms.md §6).
struct GradientParams {
  int consensus_rounds = 20;       ///< T: consensus rounds per DG-BB update
  double fixed_step = 0.1;         ///< α of fixed_step
  double step_length = 10.0;       ///< k of step_length (α = k/(√τ‖D_i‖))
  double max_step = 0.0;           ///< cap on any BB step; 0 = no cap (the source has none)
  double max_move_fraction = 1.0;  ///< BB trust region: move ≤ this × shortest range; 0 = off
  double abs_tol = 1e-10;          ///< η_abstol: a node stops when ‖α·D_i‖ falls below it
  /// local_bb: ΔD_i of Calafiore et al. eq. (15) (gradient_change = [E-6], own_move = as printed).
  LocalBbDifference local_bb_difference = LocalBbDifference::kGradientChange;
};

/// joint_field.
struct FieldParams {
  int field_warmup_steps = 0;  ///< readings of each agent's first steps are left out; 0 = Atanasov et al.
};

/// multipath_bp.
struct MultipathParams {
  /// A path's variance is σ² (range_only, Leng et al.) or also carries its angle errors (with_doa).
  PathVariance path_variance = PathVariance::kRangeOnly;
  /// Full beliefs (beliefs, Leng et al.) or cavity messages (exact, not in Leng et al.).
  BpMessages bp_messages = BpMessages::kBeliefs;
};

struct Scenario {
  std::uint64_t seed = 1;
  std::string name = "default";

  /// algorithm.*: the name and one parameter block per family (docs/scenario.md, "algorithm"). A file
  /// writes every key flat (algorithm.fixed_step); the key table maps it to its block
  /// (algorithm.gradient.fixed_step), and the registry (algorithms.hpp) says which blocks an algorithm reads.
  struct Algorithm {
    std::string name = "ieif";
    KalmanParams kalman;
    PoseParams pose;
    GradientParams gradient;
    FieldParams field;
    MultipathParams multipath;
  } algorithm;

  struct World {
    WorldSource source = WorldSource::kGenerated;
    std::string data_dir;      ///< dataset directory when source = mrclam
    double data_step_s = 0.1;  ///< dataset seconds per world step when source = mrclam
    int agents = 30;
    int anchors = 8;
    double area_m = 40.0;  ///< square side
    /// 2: the plane; 3: agents in a box area_m × area_m × height_m (dml and the centralized filters;
    /// docs/scenario.md).
    int dimensions = 2;
    double height_m = 10.0;       ///< the box's height when dimensions = 3
    double comm_radius_m = 15.0;  ///< communication = sensing radius
    Placement placement = Placement::kUniform;
    std::string positions_file;  ///< CSV "x,y" per line when placement = file
    Motion motion = Motion::kStatic;
    double motion_std_m = 0.0;  ///< random-walk step std per world step
    InitialGuess initial_guess = InitialGuess::kNoisyTruth;
    double initial_guess_std_m = 2.0;
    bool require_connected = true;  ///< redraw placement until every agent reaches an anchor
    /// Range algorithms, ≤ 1000 unknown agents: also redraw until the range Fisher information at the
    /// truth is nonsingular (every agent localizable; a non-rigid world has no meaningful error).
    bool require_localizable = true;
    // Reflecting walls for multipath (Leng et al., docs/algorithms.md §5.4): straight lines outside the area,
    // at angles first + k·step (k = 0 … wall_count−1), wall_margin_m beyond its circumscribed circle.
    int wall_count = 2;
    double wall_first_angle_deg = 0.0;
    double wall_angle_step_deg = 45.0;
    double wall_margin_m = 5.0;
    // The one target algorithm dle estimates (Atanasov et al. Sec. II): where it starts, how it moves, who
    // sees it.
    TargetMotion target_motion = TargetMotion::kStatic;
    double target_x_m = 20.0;  ///< start (the default area's centre)
    double target_y_m = 20.0;
    double target_vx_mps = 0.0;  ///< start velocity (double_integrator)
    double target_vy_mps = 0.0;
    /// q of the process covariance W (double_integrator, Atanasov et al. eq. (1))
    double target_accel_psd = 0.01;
    TargetSensing target_sensing = TargetSensing::kLinear;
    double target_sensing_radius_m = 0.0;  ///< sensors within this distance read the target; 0 = every one
    // The static scalar field of algorithm joint_field (Atanasov et al. Sec. IV, Fig. 5) on cells_per_side²
    // square cells covering the area: y ~ N(0, σ² C), C_kl = exp(−‖c_k − c_l‖² / (2ℓ²)) over the cell
    // centres.
    int field_cells_per_side = 5;  ///< ≤ 8: the INFO sample carries at most 64 values
    double field_std = 1.0;
    double field_correlation_m = 16.0;
    FieldSensing field_sensing = FieldSensing::kContinuous;
    double field_sensing_radius_m = 12.0;  ///< r_s of the continuous tents
  } world;

  struct Noise {
    double range_std_m = 0.1;
    double anchor_fix_std_m = 0.0;  ///< 0 = anchors know their position exactly
    RangeNoise range_model = RangeNoise::kAdditive;
    double range_factor = 0.0;  ///< ν_d of Calafiore et al. eq. (16); the slope of the affine model
    /// The range std of a link `distance_m` long under range_model.
    [[nodiscard]] double range_std_at(double distance_m) const {
      switch (range_model) {
        case RangeNoise::kProportional:
          return range_factor * distance_m;
        case RangeNoise::kAffine:
          return range_std_m + range_factor * distance_m;
        case RangeNoise::kAdditive:
          break;
      }
      return range_std_m;
    }
    /// Both ends of a link get the same range draw (Calafiore et al.: d̄_ij = d̄_ji).
    bool shared_range_draws = false;
    double relative_std_m = 0.1;  ///< std per axis of relative-position measurements (jacobi)
    double doa_error_deg = 5.0;   ///< angle-of-arrival error, uniform in ±this (multipath_bp)
    NoiseDraw draw = NoiseDraw::kPerStep;
    // Pose-state algorithms on recorded data (world.source = mrclam): the filters' noise model.
    /// The camera's range bias across its image, b(β) = range_bias_m + range_bias_per_rad·β +
    /// range_bias_per_rad2·β² at measured bearing β: the loader removes it from every sighting.
    double range_bias_m = 0.0;
    double range_bias_per_rad = 0.0;
    double range_bias_per_rad2 = 0.0;
    double robot_range_bias_m = 0.0;  ///< and a sighting of a robot reads this much longer still
    double bearing_std_rad = 0.05;    ///< robot-frame bearing std
    double odometry_v_std = 0.05;     ///< m/√s on the travelled distance
    double odometry_omega_std = 0.1;  ///< rad/√s on the turned angle
    /// The robots follow their velocity commands this late: the loader gives step (t_{k−1}, t_k] the
    /// commands in force over (t_{k−1} − lag, t_k − lag].
    double odometry_lag_s = 0.0;
    /// Sightings' errors correlated in time: white + first-order Gauss–Markov parts (estimators'
    /// KalmanFilterParams, docs/algorithms.md §10.3); τ = 0: independent.
    double sighting_correlation_time_s = 0.0;
    double range_correlated_fraction = 0.0;
    double bearing_correlated_fraction = 0.0;
    /// Landmarks within this distance of one another share one correlated error stream (0 = each its own).
    double sighting_cluster_radius_m = 0.0;
    double target_std_m = 1.0;             ///< dle target readings: std per axis (linear) or of the range
    double target_bearing_std_rad = 0.05;  ///< dle range–bearing readings: bearing std
    double field_std = 0.1;                ///< joint_field readings: std of each scalar reading
  } noise;

  struct Network {
    double loss = 0.0;  ///< mean loss at the receiver, [0, 1]
    struct Burst {
      double mean_length = 0.0;  ///< 0 = Bernoulli; else Gilbert–Elliott mean burst (samples)
    } burst;
    // Simulated latency of every sample and batch (run.sim_clock = agents only; DDS has real latency).
    double delay_ms = 0.0;   ///< fixed part
    double jitter_ms = 0.0;  ///< plus a seeded uniform draw in [0, jitter_ms) per delivery
  } network;

  struct Clock {
    double drift_ppm = 0.0;
    double offset_max_s = 0.0;
  } clock;

  struct Run {
    int steps = 300;
    double rate_hz = 10.0;
    RunMode mode = RunMode::kFreeRun;
    double startup_timeout_s = 30.0;         ///< agents must report within this time
    double settle_s = 1.0;                   ///< extra time after the last step for final estimates
    SimClock sim_clock = SimClock::kRounds;  ///< the simulator's schedule (DDS runs ignore it)
    int agent_nice = 0;  ///< DDS: agent processes run this much nicer than the orchestrator
    /// Agent steps (one exchange with the neighbours each) per world step; the first gets the batch.
    int agent_steps_per_world_step = 1;
    TickPhase tick_phase = TickPhase::kSpread;  ///< free run, DDS and run.sim_clock = agents
  } run;

  struct Qos {
    QosSettings measurements{Reliability::kReliable, 4, Durability::kVolatile, 0.0, 0.0};
    QosSettings state{Reliability::kBestEffort, 1, Durability::kVolatile, 0.0, 0.0};
    QosSettings information{Reliability::kBestEffort, 1, Durability::kVolatile, 0.0, 0.0};
    QosSettings consensus{Reliability::kBestEffort, 8, Durability::kVolatile, 0.0, 0.0};
    QosSettings belief{Reliability::kBestEffort, 1, Durability::kVolatile, 0.0, 0.0};
    QosSettings estimate{Reliability::kReliable, 4, Durability::kVolatile, 0.0, 0.0};
    QosSettings control{Reliability::kReliable, 4, Durability::kTransientLocal, 0.0, 0.0};
  } qos;

  /// Scheduled faults (docs/design.md §5), each a short list in a string (docs/scenario.md, "faults").
  struct Faults {
    std::string kill;   ///< "AGENT@STEP[-RESTART], …": kill -9 at STEP, restart (fresh state) at RESTART
    std::string pause;  ///< "AGENT@STEP-RESUME, …": SIGSTOP at STEP, SIGCONT at RESUME
    std::string partition;  ///< "STEP-STEP": split into a west and an east half (by true x), heal after
  } faults;

  struct Dds {
    int domain_id = 0;
    std::string interface = "lo";     ///< network interface for Cyclone
    bool neighbour_discovery = true;  ///< unicast, per-agent Peers lists (docs/design.md §4)
    std::string peer_address = "127.0.0.1";
    std::string security_dir;  ///< DDS Security PKI (deploy/security/make-pki.sh); empty: no security
    /// Prefix of every partition name, so no sample of one run reaches another run's processes on the
    /// same domain. Empty: `swarmloc run` draws a fresh one and writes it to the run directory's
    /// scenario.yaml, which agents started elsewhere read (docs/robustness.md, "Run isolation").
    std::string run_id;
    /// Also speak ROS 2 (docs/ros2.md): agents publish their estimate as
    /// geometry_msgs/PoseWithCovarianceStamped, the orchestrator the truth and the ranges, on `rt/swarmloc/…`
    /// topics in the default partition.
    bool ros2 = false;
  } dds;
};

/// One agent fault of faults.kill / faults.pause: from `from_step` until `to_step` (−1: for good).
struct AgentFault {
  AgentId agent = 0;
  std::int64_t from_step = 0;
  std::int64_t to_step = -1;
};
/// Parses faults.kill (require_end = false) or faults.pause (true). Throws ScenarioError naming `key`.
std::vector<AgentFault> parse_agent_faults(const std::string& text, const std::string& key, bool require_end);

/// faults.partition: the steps [from_step, to_step] during which the two halves cannot talk.
struct StepWindow {
  std::int64_t from_step = 0;
  std::int64_t to_step = -1;
};
/// Empty text: no window. Throws ScenarioError naming faults.partition.
std::optional<StepWindow> parse_partition(const std::string& text);

/// Loads and validates a scenario file; `overrides` are "key.path=value" strings applied before
/// validation. Throws ScenarioError naming the key path. `warnings`, if given, receives one line per
/// algorithm key the chosen algorithm does not read (its block is another family's) that was set by
/// --set, or in the file to other than its default: "algorithm.fixed_step: not used by ieif (…) at …".
Scenario load_scenario(const std::string& path, const std::vector<std::string>& overrides = {},
                       std::vector<std::string>* warnings = nullptr);

/// Parses YAML text (same rules as load_scenario; `origin` names the source in errors).
Scenario parse_scenario(const std::string& yaml_text, const std::vector<std::string>& overrides = {},
                        const std::string& origin = "<string>", std::vector<std::string>* warnings = nullptr);

/// Checks every cross-field rule (anchors <= agents, loss in [0,1], …). Throws ScenarioError.
void validate(const Scenario& scenario);

/// Serializes the full scenario with every default filled in (the run directory's scenario.yaml).
std::string to_yaml(const Scenario& scenario);

/// Stable 64-bit hash of to_yaml(scenario), dds.run_id left out (the same scenario hashes the same in
/// every run).
std::uint64_t scenario_hash(const Scenario& scenario);

/// Hash of what decides a run's results: everything but `name` and the transport settings (dds.*),
/// which may differ between hosts. Agents and the orchestrator must agree on it (Control, Estimate).
std::uint64_t results_hash(const Scenario& scenario);

/// True if `run_id` may be a dds.run_id: 1 to 32 characters of [A-Za-z0-9_-].
bool valid_run_id(const std::string& run_id);

/// Every canonical key path accepted by --set (for --help and tests).
const std::vector<std::string>& known_keys();

/// The algorithms whose agent step without a measurement is an exchange alone, the only ones that take
/// run.agent_steps_per_world_step > 1 (the estimators' cooperative family; a test keeps the two equal).
const std::vector<std::string>& exchange_only_algorithms();

}  // namespace swarmloc::config
