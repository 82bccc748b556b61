#pragma once
// The agent's loop: when it steps and what it does with what arrives, independent of the transport
// (docs/architecture.md, "One agent loop"). The DDS agent process drives it with the monotonic clock and
// its DDS topics; the simulator's agent-clock schedule drives it with virtual time and a seeded network.
// Both therefore tick, hold, release, report and notice silence by the same code.
//
//   free run:  a timer on the agent's own clock: tick m of a timer started at s falls at
//              s + (φ + m)·T/(1 + drift) (T: the world period over run.agent_steps_per_world_step,
//              φ: tick_phase_fraction); a tick that comes late steps once and skips the ticks it missed.
//   lockstep:  one step per world-step batch; inter-agent samples wait until the step they belong to
//              (a sample of step s is used from step s + 1 on, as the simulator's rounds deliver it).
//   sensor only (a centralized algorithm): no estimator steps; a hello every 0.5 s.
#include <cstdint>
#include <limits>
#include <optional>
#include <variant>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/core/clock.hpp"
#include "swarmloc/runtime/agent_runtime.hpp"
#include "swarmloc/runtime/manifest.hpp"
#include "swarmloc/runtime/run_health.hpp"
#include "swarmloc/runtime/sample_log.hpp"

namespace swarmloc::runtime {

/// Where the loop sends what the agent produces: the DDS agent writes topics, the simulator queues
/// deliveries. Calls come from the thread that drives the loop.
class AgentPort {
 public:
  AgentPort() = default;
  virtual ~AgentPort() = default;
  AgentPort(const AgentPort&) = delete;
  AgentPort& operator=(const AgentPort&) = delete;
  AgentPort(AgentPort&&) = delete;
  AgentPort& operator=(AgentPort&&) = delete;

  /// The samples of one step, or the announcement of the agent's prior.
  virtual void publish(const AgentRuntime::Publication& publication) = 0;
  /// Lockstep: returns once the step's samples are with every neighbour (the report that follows tells
  /// the orchestrator the step is done).
  virtual void flush() {}
  /// The estimate report: one per world period, and the hellos of a sensor-only agent.
  virtual void report(const EstimateReport& report) = 0;
};

/// What the loop needs to know of the run: from the scenario and the agent's manifest.
struct LoopSettings {
  AgentId id = 0;
  core::ClockModel clock;
  double world_period_s = 0.1;      ///< 1 / run.rate_hz
  int steps_per_world_step = 1;     ///< run.agent_steps_per_world_step
  double phase_fraction = 0.0;      ///< tick_phase_fraction: where in its period the timer fires
  bool lockstep = false;            ///< run.mode = lockstep: steps on batches
  bool sensor_only = false;         ///< a centralized algorithm: the fusion centre estimates
  bool hostile = false;             ///< publishes garbage after its first sample (robustness tests)
  double startup_timeout_s = 60.0;  ///< run.startup_timeout_s: lockstep's silence limit
  std::uint64_t results_hash = 0;   ///< config::results_hash of the agent's scenario, in its reports
  bool reports = true;              ///< false: no estimate reports (the simulator reads estimates itself)
};

/// LoopSettings of the agent `manifest` describes in `scenario`; `hostile` as given.
LoopSettings loop_settings(const config::Scenario& scenario, const AgentManifest& manifest,
                           bool hostile = false);

/// One inter-agent sample of any family, as a transport receives it.
struct InboundSample {
  Header header;
  SampleMessage message;
  bool well_formed = true;
};

class AgentLoop {
 public:
  AgentLoop(AgentRuntime runtime, const LoopSettings& settings, AgentPort& port);

  /// Publishes the agent's prior (header.step = −1) at `now_s` (free run: at launch and when a neighbour
  /// first listens; lockstep: once, when every neighbour can receive it).
  void announce(double now_s);
  /// START: the timer starts now; its first tick is one local period (plus the phase) later.
  void start(double now_s);
  [[nodiscard]] bool started() const { return started_; }

  /// A measurement batch arrived at `now_s`.
  void on_batch(const Header& header, estimators::MeasurementBatch batch, double now_s);
  /// An inter-agent sample arrived at `now_s`: free run hands it to the runtime now, lockstep holds it
  /// until the step it belongs to.
  void on_sample(const InboundSample& sample, double now_s);

  /// Runs what is due at `now_s`: a tick (free run), a step per pending batch (lockstep), a hello (sensor
  /// only). Returns the number of estimator steps run.
  int advance(double now_s);
  /// When advance() next has something to do by the clock (+inf: only when data arrive).
  [[nodiscard]] double next_due_s() const;

  /// The simulator's faults.pause: ticks pass without a step while paused (a real process is stopped).
  void set_paused(bool paused) { paused_ = paused; }

  /// True when the orchestrator has sent no batch for too long (free run: max(5 s, 50 world periods);
  /// lockstep: run.startup_timeout_s). Time this process did not run (a gap of over 1 s between two
  /// calls) does not count.
  [[nodiscard]] bool orchestrator_silent(double now_s);
  [[nodiscard]] double silent_for_s(double now_s) const { return now_s - last_batch_s_; }
  [[nodiscard]] std::size_t held_samples() const { return held_.size(); }

  /// The estimate report at `now_s`; cpu_s: the process's CPU since START.
  [[nodiscard]] EstimateReport report(double now_s, double cpu_s) const;
  /// The agent's clock reading at `now_s`, in integer nanoseconds (sample stamps).
  [[nodiscard]] std::int64_t local_stamp_ns(double now_s) const;

  [[nodiscard]] const AgentRuntime& runtime() const { return runtime_; }
  [[nodiscard]] AgentRuntime& runtime() { return runtime_; }
  [[nodiscard]] const HealthMeter& health() const { return health_; }
  [[nodiscard]] const LoopSettings& settings() const { return settings_; }
  /// The report's CPU figure; set by the driver (the simulator leaves it at 0).
  void set_cpu_s(double cpu_s) { cpu_s_ = cpu_s; }

 private:
  [[nodiscard]] double tick_period_s() const;
  [[nodiscard]] double tick_time_s(std::int64_t index) const;
  /// A gap of over a second since the last call: this process did not run; the silence timer moves on
  /// by the gap (never past now).
  void note_time(double now_s);
  int tick(double now_s);
  int step_lockstep(double now_s);
  void release_held(std::int64_t step);
  void step(double now_s);
  void note_step(double now_s);

  AgentRuntime runtime_;
  LoopSettings settings_;
  AgentPort& port_;
  HealthMeter health_;
  bool started_ = false;
  bool paused_ = false;
  double timer_start_s_ = 0.0;
  std::int64_t next_tick_ = 1;  ///< free run: the index of the next tick of the timer
  double last_batch_s_ = 0.0;   ///< the silence timer
  double last_call_s_ = std::numeric_limits<double>::quiet_NaN();
  double next_hello_s_ = 0.0;
  int ticks_since_report_ = 0;
  double cpu_s_ = 0.0;
  std::vector<InboundSample> held_;  ///< lockstep: samples of steps not yet run
  std::optional<double> batch_waiting_since_s_;
  /// When each neighbour's newest sample arrived (NaN: not heard yet), by its slot in the runtime's list.
  std::vector<double> last_heard_s_;
};

}  // namespace swarmloc::runtime
