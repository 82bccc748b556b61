#pragma once
// The Kalman family's parameters (docs/algorithms.md §3), which the dml and pose filters read too.

namespace swarmloc::estimators {

/// Algorithm parameters shared by the distributed Kalman family (docs/algorithms.md §3).
struct KalmanFilterParams {
  double process_noise_std_m = 0.01;       ///< Q = std²·I per step ([B-6])
  double initial_information = 1e-6;       ///< IEIF Ψ_0 = ε·I (m⁻²)
  double initial_std_m = 8.66;             ///< IEKF P_0 = std²·I
  bool inflate_stale = true;               ///< §3.4 rule (2)
  double max_neighbour_variance_m2 = 1e6;  ///< neighbours with trace(P) above this are skipped
  double range_gate_chi2 = 0.0;            ///< drop a range if ν² > gate·s (1 dof); 0 = no gate
  /// IEIF, IEKF: Gauss–Newton passes of a step's range update from the same prior (the iterated
  /// extended filter); 1 = Gasparri & Pascucci's single linearization at x̂_{k|k−1}.
  int update_iterations = 1;
  // Pose-state algorithms (pose_ekf, pose_ieif, dead_reckoning): prior around AgentSetup's pose.
  double initial_heading_std_rad = 0.1;
  double range_bearing_gate_chi2 = 0.0;  ///< drop a range-bearing pair if ν'S⁻¹ν > gate (2 dof); 0 = off
  /// Sightings whose errors are correlated in time (docs/algorithms.md §10.3): each channel's error is a
  /// white part plus a first-order Gauss–Markov part (this fraction of its variance, correlation time τ).
  /// 0 = independent sightings.
  double sighting_correlation_time_s = 0.0;
  double range_correlated_fraction = 0.0;
  double bearing_correlated_fraction = 0.0;
  /// Landmarks this close to one another share one error stream (seen in one camera frame, their errors
  /// are nearly the same): their sightings are weighed as repeats of one target. 0 = each its own.
  double sighting_cluster_radius_m = 0.0;
  /// team_pose_ekf (docs/algorithms.md §10): spans of its own data each sample repeats (a peer that lost
  /// up to team_share_spans − 1 samples in a row still gets every span), and the world steps the settled
  /// filter waits for a member's data before it steps without it.
  int team_share_spans = 50;
  int team_wait_steps = 50;
};

}  // namespace swarmloc::estimators
