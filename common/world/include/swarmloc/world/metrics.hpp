#pragma once
// Scoring estimates against truth (docs/algorithms.md §1.4) and the CRLB reference (§1.3).
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include "swarmloc/estimators/messages.hpp"
#include "swarmloc/models/pose_models.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::world {

/// Error statistics over the non-anchor agents at one instant.
struct ErrorStats {
  double rmse_m = 0.0;
  double mean_error_m = 0.0;
  double max_error_m = 0.0;
  double nees =
      0.0;  ///< mean of eᵀP⁻¹e over agents with a valid covariance (2 if consistent, 3 in a 3-D world)
  int nees_agents = 0;  ///< scored agents whose covariance is valid and positive definite: the NEES's sample
  int scored = 0;       ///< non-anchor agents with an estimate
  int missing = 0;  ///< non-anchor agents without any estimate yet, or without ground truth (recorded gaps)
  /// Non-anchor agents whose estimate holds NaN or Inf (in its mean, or in a covariance it calls valid): a
  /// broken estimate, not a missing one. Any makes rmse_m, mean_error_m and max_error_m (mean) or nees
  /// (covariance) +inf, so a diverged agent can never leave a clean-looking figure (docs/robustness.md,
  /// "Non-finite estimates").
  int non_finite = 0;
  int flagged = 0;  ///< scored agents whose self-check finds them inconsistent (docs/algorithms.md §1.6)
  /// joint_field: sqrt of the mean over agents with a field estimate of ‖ŷ_i − y‖² / cells (NaN otherwise).
  double field_rmse = std::numeric_limits<double>::quiet_NaN();
  int field_scored = 0;
};

/// `estimates[i]` may be nullopt (no report from agent i yet): counted as missing, not scored. A non-finite
/// estimate is counted in ErrorStats::non_finite and poisons the step's figures. `truth_z` (a 3-D world):
/// each truth's z; errors and NEES are then in space, and an estimate without a z counts as missing.
ErrorStats score(const std::vector<Vec2>& truth, const std::vector<bool>& is_anchor,
                 const std::vector<std::optional<estimators::Estimate>>& estimates,
                 const std::vector<double>* truth_z = nullptr);

/// Scores every agent World::scored says is scored against World::scored_truth: the non-anchor agents'
/// positions, or every sensor's estimate of the target. In a field world it also scores every agent's
/// (anchors' too) field estimate against World::field.
ErrorStats score(const World& world, const std::vector<std::optional<estimators::Estimate>>& estimates);

/// 3-DOF NEES of a pose estimate (pose-state algorithms, docs/real-data.md): eᵀ P⁻¹ e with
/// e = (x − x_t, y − y_t, wrap(θ − θ_t)), the heading error wrapped to (−π, π], P the (x, y, θ) covariance
/// (3 if consistent). nullopt if e or P is not finite or P is not positive definite.
std::optional<double> pose_nees(const models::Pose& estimate, const models::Mat3& covariance,
                                const models::Pose& truth);
/// The same for an Estimate: nullopt without a heading, when not valid, or with a non-finite truth.
std::optional<double> pose_nees(const estimators::Estimate& estimate, const Vec2& truth_m,
                                double truth_heading_rad);

/// Mean of NEES values over the samples that have one.
struct MeanNees {
  double sum = 0.0;
  std::size_t count = 0;
  void add(std::optional<double> nees) {
    if (nees) sum += *nees, ++count;
  }
  [[nodiscard]] double mean() const {
    return count > 0 ? sum / static_cast<double>(count) : std::numeric_limits<double>::quiet_NaN();
  }
};

/// CRLB of the static range network of `world` (each endpoint measures each edge once per snapshot,
/// anchors exactly known): network RMSE bound for one snapshot and per agent.
struct RangeCrlb {
  double single_snapshot_rmse_m = 0.0;  ///< sqrt(tr(J_1⁻¹)/n_u); +inf if not localizable
  std::vector<double> per_agent_single_rmse_m;
  bool localizable = true;
  bool fresh_draws_per_step = true;  ///< false (noise.draw = once): later steps add no information
  /// Accumulated over t independent snapshots of a static network: J_t = t·J_1 (J_1 if the noise is
  /// drawn once).
  [[nodiscard]] double accumulated_rmse_m(double snapshots) const;
};
RangeCrlb range_crlb(const World& world, double range_std_m);

/// The Fisher information about the target's position at `target` from one step of every sensor's reading
/// (sensors within world.target_sensing_radius_m; linear or range–bearing readings, as world.cpp draws them).
Mat2 target_information(const World& world, const config::Scenario& scenario, const Vec2& target);

/// The bound that matches the scenario's measurements (at the initial truth): ranges (additive or
/// proportional noise), relative positions (each link one shared draw: the BLUE covariance σ²·L⁻¹ per
/// axis), a static target's readings (the centralized estimate from every sensor's readings; the same
/// bound for each sensor), reflected paths (eq. (1) with the noise-free angles taken as exact,
/// docs/algorithms.md §5.4: angle errors are not in it), or NaN for a moving target (no bound implemented).
/// Anchors are known.
RangeCrlb scenario_crlb(const World& world, const config::Scenario& scenario);

}  // namespace swarmloc::world
