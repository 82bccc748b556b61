#pragma once
// Reproduction experiments of Atanasov et al. (docs/algorithms.md §4.6): distributed Jacobi localization from
// relative measurements against the centralized BLUE and its CRB, and the static-target DLE. Library
// functions returning numbers (no I/O); all randomness from the seeds in the configs.
#include <cstdint>
#include <vector>

#include "swarmloc/estimators/consensus/joint_field.hpp"

namespace swarmloc::research {

/// How the Atanasov et al. localization graph is drawn ([C-5]: the source says only "randomly generated
/// graphs with 300 nodes and 1288 edges").
enum class RelativeGraphModel {
  kGeometric,  ///< docs/algorithms.md §4.6 default: uniform points, the radius giving exactly num_edges edges
  kGnm,        ///< Erdős–Rényi G(n, m): num_edges pairs drawn uniformly, whatever their distance
};

struct JacobiExperimentConfig {
  int num_nodes = 300;
  int num_edges = 1288;  ///< exactly this many edges ([C-5])
  RelativeGraphModel graph_model = RelativeGraphModel::kGeometric;
  double side_m = 100.0;           ///< square domain
  double prior_std_m = 5.0;        ///< x̂_i(0) = x_i + N(0, std² I)
  double measurement_std_m = 1.0;  ///< 𝓔_ij = std² I₂
  int steps = 50;
  int sweeps_per_step = 1;  ///< eq. (9) exchanges per measurement step (1 = Atanasov et al. as printed)
  int runs = 50;            ///< a fresh connected graph, priors and noise per run
  bool shared_measurements = true;  ///< [C-7]: one draw per edge per step, s_ji = −s_ij
  std::uint64_t seed = 1;
  int max_graph_attempts = 10000;
};

struct JacobiExperimentResult {
  /// Index t = 0…steps, all over non-reference nodes and runs ([C-6]).
  std::vector<double> rmse;         ///< Jacobi x̂(t) (t = 0: the priors)
  std::vector<double> blue_rmse;    ///< centralized BLUE on the samples 0…t−1 ([0] = NaN)
  std::vector<double> crb_rmse;     ///< sqrt(tr((c·t·L̃)⁻¹)/(n−1)), c = 1 (shared) or 2 ([0] = NaN)
  double mean_radius_m = 0.0;       ///< kGeometric: the radius that gave num_edges edges
  double mean_edge_length_m = 0.0;  ///< mean true length of an edge
  int graphs_rejected = 0;          ///< disconnected draws
};

/// Atanasov et al. Figs. 2, 4: node 0 is the reference (fixed at 0); truth is expressed in its frame.
JacobiExperimentResult run_jacobi_experiment(const JacobiExperimentConfig& config);

struct StaticDleExperimentConfig {
  int num_nodes = 30;
  double side_m = 100.0;
  double radius_m = 35.0;        ///< disk graph, redrawn until connected
  int target_dim = 4;            ///< d_y; each sensor sees only a random 2×d_y projection H_i
  double target_std = 10.0;      ///< y ~ N(0, std² I)
  double observation_std = 1.0;  ///< V_i = std² I₂
  int steps = 100;
  int runs = 20;
  std::uint64_t seed = 1;
};

struct StaticDleExperimentResult {
  /// Index t = 1…steps ([0] unused = NaN): mean over runs and over the nodes with an estimate.
  std::vector<double> mse;
  std::vector<double> centralized_mse;  ///< centralized information filter on all observations so far
  std::vector<double> centralized_crb;  ///< tr((t Σ_i H_iᵀV_i⁻¹H_i)⁻¹)
  std::vector<double> fraction_with_estimate;
};

/// Static target (F = I, W = 0), Atanasov et al. Algorithm 1 with Metropolis weights.
StaticDleExperimentResult run_static_dle_experiment(const StaticDleExperimentConfig& config);

/// Where the field experiment puts its sensors.
enum class SensorPlacement {
  kUniform,  ///< uniform in the square
  /// On cell boundaries (Atanasov et al. Fig. 5's "additional experiment"): sensor i on the left or bottom
  /// edge of cell i mod cells², so every cell has sensors of its own
  kCellBoundaries,
};

struct JointFieldExperimentConfig {
  /// Atanasov et al. does not give Fig. 5's sensor count: the graph of Figs. 2, 4. (100 sensors leave the 10
  /// × 10 field poorly observed: the centralized filter with true positions stalls near 0.3.)
  int num_nodes = 300;
  int num_edges = 1288;  ///< exactly this many edges: the radius is the num_edges-th smallest distance
  double side_m = 100.0;
  int cells_per_side = 10;  ///< the field grid covers the square
  double sensing_radius_m = 15.0;
  estimators::consensus::FieldSensing sensing = estimators::consensus::FieldSensing::kContinuous;
  SensorPlacement placement = SensorPlacement::kUniform;
  /// y ~ N(0, σ² C), C_kl = exp(−‖c_k − c_l‖² / (2ℓ²)) over the cell centres (a discrete Gaussian random
  /// field).
  double field_std = 1.0;
  double field_correlation_m = 20.0;
  double observation_std = 0.1;    ///< V_i = std² (scalar readings)
  double prior_std_m = 5.0;        ///< x̂_i(0) = x_i + N(0, std² I) (as Figs. 2, 4)
  double measurement_std_m = 1.0;  ///< 𝓔_ij = std² I₂, one shared draw per edge and step ([C-7])
  double delta = 1e-3;
  int steps = 100;
  int runs = 50;
  std::uint64_t seed = 1;  ///< run r draws from seed_seq{seed, r}
  int threads = 1;         ///< runs in parallel; results are identical for any count
  int max_graph_attempts = 10000;
};

struct JointFieldExperimentResult {
  /// Index t = 0…steps, means over runs. Location: over non-reference sensors ([C-6]); field: over all
  /// sensors and cells. Field entries at t = 0 are NaN (no estimate before the first step).
  std::vector<double> location_rmse;
  std::vector<double> field_rmse;                 ///< the joint procedure (eq. (10))
  std::vector<double> known_position_field_rmse;  ///< the same DLE with the true sensor positions (§4.6)
  std::vector<double> centralized_field_rmse;     ///< centralized information filter, true positions
  double mean_radius_m = 0.0;
  int graphs_rejected = 0;
};

struct TrackingExperimentConfig {
  /// Sensor 0 at the origin, the others uniform in the square (Atanasov et al. Figs. 1, 3).
  int num_sensors = 40;
  int num_targets = 10;
  double side_m = 100.0;
  double radius_m = 30.0;  ///< communication disk; the draw is repeated until connected
  double dt_s = 1.0;       ///< τ
  double q = 0.1;          ///< W = q [[τ³/3 I, τ²/2 I], [τ²/2 I, τ I]]
  double range_std_m = 0.1, range_std_per_m = 0.01;          ///< std = a + b · distance
  double bearing_std_rad = 0.01, bearing_std_per_m = 0.001;  ///< std = a + b · distance
  double start_std_m = 1.0;                                  ///< targets start at N(0, std² I) …
  double speed_mps = 1.0;  ///< … moving at this speed, direction uniform in [0, π/2] (into the square)
  double initial_information = 1e-6;  ///< Ω_0 = ε I (§4.2)
  int steps = 50;
  int runs = 50;
  std::uint64_t seed = 1;
};

struct TrackingExperimentResult {
  /// Index t = 1…steps ([0] = NaN); RMSE over runs and targets of the position / velocity estimate.
  std::vector<double> node0_position_rmse, others_position_rmse, centralized_position_rmse;
  std::vector<double> node0_velocity_rmse, others_velocity_rmse, centralized_velocity_rmse;
};

/// Atanasov et al. Figs. 1, 3: every sensor runs one DLE per target (range–bearing, linearized at its
/// prediction; known data association), against a centralized EKF on all sensors' readings.
TrackingExperimentResult run_tracking_experiment(const TrackingExperimentConfig& config);

/// Atanasov et al. Fig. 5: joint localization (Jacobi, node 0 the reference) and estimation of a static
/// field.
JointFieldExperimentResult run_joint_field_experiment(const JointFieldExperimentConfig& config);

}  // namespace swarmloc::research
