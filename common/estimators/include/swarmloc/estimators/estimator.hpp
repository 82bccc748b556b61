#pragma once
// The one interface every per-agent algorithm implements. Plain C++/Eigen in, plain C++/Eigen out:
// no DDS, clock, RNG, I/O or logging inside. Two runtimes drive it: the DDS agent process
// (agent/) and the in-process simulator (common/sim).
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "swarmloc/estimators/messages.hpp"

namespace swarmloc::estimators {

/// Input to one step of agent i's estimator.
struct StepInput {
  std::int64_t local_step = 0;                     ///< agent's own step counter (0, 1, 2, …)
  const MeasurementBatch* measurements = nullptr;  ///< newest batch not yet used; nullptr if none
  const Inbox* inbox = nullptr;                    ///< newest sample per neighbour
};

/// Counters an estimator reports about one step (the runtime aggregates and logs them).
struct StepDiagnostics {
  int neighbours_used = 0;
  int neighbours_skipped = 0;  ///< no fresh measurement, infinite covariance, …
  int ranges_gated = 0;        ///< ranges rejected by the chi-square innovation gate (not in neighbours_used)
  bool updated = false;        ///< false: prediction only
};

struct StepOutput {
  Outbox outbox;
  StepDiagnostics diagnostics;
};

/// Static facts an agent knows about itself when it starts.
struct AgentSetup {
  AgentId id = 0;
  bool anchor = false;
  Vec2 initial_guess_m = Vec2::Zero();  ///< for anchors: the known position
  double initial_heading_rad = 0.0;     ///< pose-state algorithms: the heading they start from
  /// How far off initial_guess_m may be (std per axis); +inf: nothing is known about it.
  double initial_guess_std_m = std::numeric_limits<double>::infinity();
  /// The communication radius: a link exists exactly between agents within it at step 0 (a disk graph), so
  /// an agent that does not hear another is farther from it (dml, docs/algorithms.md §9.4); +inf: unknown.
  double comm_radius_m = std::numeric_limits<double>::infinity();
};

class Estimator {
 public:
  virtual ~Estimator() = default;
  Estimator() = default;
  Estimator(const Estimator&) = delete;
  Estimator& operator=(const Estimator&) = delete;
  Estimator(Estimator&&) = delete;
  Estimator& operator=(Estimator&&) = delete;

  [[nodiscard]] virtual std::string_view name() const = 0;
  /// What to publish before the first step (so neighbours can linearize at step 0).
  [[nodiscard]] virtual Outbox initial_outbox() const = 0;
  /// Runs one local step with the newest data available.
  virtual StepOutput step(const StepInput& input) = 0;
  [[nodiscard]] virtual Estimate estimate() const = 0;
};

/// Algorithm parameters shared by the distributed Kalman family (docs/algorithms.md §3).
struct KalmanFamilyParams {
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
};

/// Builds the estimator named `algorithm` ("ieif", "iekf", …). Throws std::invalid_argument for an
/// unknown name (the message lists the known ones).
std::unique_ptr<Estimator> make_estimator(const std::string& algorithm, const AgentSetup& setup,
                                          const KalmanFamilyParams& params);

/// Names accepted by make_estimator.
const std::vector<std::string>& known_algorithms();

}  // namespace swarmloc::estimators
