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
  /// 2: a planar world; 3: positions have a z too (world.dimensions, docs/design.md §3.1).
  int dimensions = 2;
  double initial_altitude_m = 0.0;  ///< 3-D: the z of initial_guess_m
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

}  // namespace swarmloc::estimators
