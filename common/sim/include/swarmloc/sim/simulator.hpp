#pragma once
// The in-process runtime: the same AgentRuntime + estimator code as the DDS agents, driven either in
// synchronous rounds or with each agent on its own clock (run.sim_clock), over a seeded bus that
// applies the same receiver-side loss model.
#include <functional>

#include "swarmloc/rundir/recording.hpp"
#include "swarmloc/rundir/run_record.hpp"
#include "swarmloc/runtime/agent_runtime.hpp"
#include "swarmloc/runtime/manifest.hpp"

namespace swarmloc::sim {

struct SimOptions {
  bool record_estimates = true;  ///< keep per-agent per-step rows (estimates.csv)
  /// Called after every step with (step, errors) — for progress lines. May be empty.
  std::function<void(std::int64_t, const world::ErrorStats&)> on_step;
  std::uint64_t trial = 0;  ///< Monte Carlo trial (see World::trial)
  /// Agents that publish garbage (make_hostile) after their initial sample, like `swarmloc run
  /// --hostile`; they still estimate for themselves and are scored.
  std::vector<AgentId> hostile_agents;
  /// Replay: truth and batches come from here (World::recorded) instead of the seeded generator.
  std::shared_ptr<const world::RecordedSteps> recorded;
  /// --record: receives the world, every world step's truth and batches, and every inter-agent sample
  /// an agent receives (not owned; single runs only).
  rundir::RunRecorder* recorder = nullptr;
  /// run.sim_clock = rounds: threads that deliver, generate batches and step the agents of one round
  /// (each touches only its own agents, so the result is identical for any count); 1 = serial, 0 =
  /// auto_round_threads. Runs with a recorder or a replayed world are always serial (ordered side effects).
  int round_threads = 1;
  /// Progress of the long phases (the world, the agents, a step's rounds) and cancellation, polled per
  /// agent. Set before the first step: run_simulation throws Cancelled; later it returns the steps done
  /// with RunRecord::interrupted set (a step cut short is not scored; with a recorder, recording.slrec may
  /// hold its measurements). run.sim_clock = agents and centralized algorithms report per step only.
  world::WorkControl control;
};

/// Below this many agents a round is too short (~4 µs per agent) to pay for starting threads.
inline constexpr int kParallelRoundsFromAgents = 1000;

/// Threads for one run's rounds when the user did not say: every core from kParallelRoundsFromAgents
/// agents on (N = 10^4 on 2 cores: 52-58 ms per step serial, 26-27 ms on two threads), else 1.
int auto_round_threads(int agents);

/// Runs `scenario` in-process, deterministic in the seed. run.sim_clock = rounds: synchronous rounds —
/// at round k every agent receives its world-step-k batch and the samples its neighbours published in
/// round k−1, then steps. run.sim_clock = agents: run_agent_clock_simulation.
/// Centralized algorithms (ekf, lbekf*) delegate to run_centralized_simulation (centralized_runner.hpp).
rundir::RunRecord run_simulation(const config::Scenario& scenario, const SimOptions& options = {});
/// The same on `world` = build_world(scenario, options.trial), e.g. the one a preflight check built (at
/// 10^5 agents a dense world takes minutes to build). run.sim_clock = agents and centralized algorithms
/// build their own.
rundir::RunRecord run_simulation(const config::Scenario& scenario, world::World world,
                                 const SimOptions& options);

/// Quiet rounds after the last world step in free run: round(run.settle_s · run.rate_hz ·
/// run.agent_steps_per_world_step), as many exchanges as the DDS agents make while the orchestrator
/// settles (docs/algorithms.md §9.2); 0 in lockstep mode, where DDS agents step only on batches. The
/// last step is re-scored after them (the final figures, metrics' and estimates' last step).
std::int64_t settle_rounds(const config::Scenario& scenario);

/// run.sim_clock = agents: a discrete-event simulation on virtual time. World step k's batches are
/// published at k·T (T = 1/run.rate_hz) and the truth advances then; agent i's timer starts with the
/// run and ticks every local period T of its own clock (every T/(1+drift_i) of virtual time, the
/// clock the DDS agent draws); a tick steps the agent on its newest batch and mailbox and publishes.
/// Samples and batches arrive after network.delay_ms + U[0, network.jitter_ms). World step k is scored
/// at (k+1)·T with each agent's newest estimate; in free run the last one again at run.steps·T +
/// run.settle_s, the agents ticking on with no new batch (settle_rounds). Throws config::ScenarioError for a
/// centralized algorithm (see require_supported_sim_clock).
rundir::RunRecord run_agent_clock_simulation(const config::Scenario& scenario,
                                             const SimOptions& options = {});

/// Throws config::ScenarioError naming run.sim_clock when the scenario's schedule cannot be simulated:
/// run.sim_clock = agents with a centralized algorithm (its fusion centre consumes whole world steps).
void require_supported_sim_clock(const config::Scenario& scenario);

/// Per-step statistics across Monte Carlo trials (mean and standard deviation over trials).
struct MonteCarloStep {
  std::int64_t step = 0;
  double mse_mean = 0.0, mse_std = 0.0;    ///< mean squared error per non-anchor agent (m²)
  double rmse_mean = 0.0, rmse_std = 0.0;  ///< per-trial network RMSE (m)
  double nees_mean = 0.0, nees_std = 0.0;
  double crlb_rmse_m = 0.0;
  /// sqrt of the mean over trials of the run's bound² (a PCRB differs per trial: each has its trajectory).
  double bound_rmse_m = std::numeric_limits<double>::quiet_NaN();
  double bound_all_data_rmse_m = std::numeric_limits<double>::quiet_NaN();
  /// sqrt of the mean over trials of the optimum² (docs/algorithms.md §1.3.2; NaN off its checkpoints).
  double optimum_rmse_m = std::numeric_limits<double>::quiet_NaN();
};
struct MonteCarloResult {
  std::vector<MonteCarloStep> steps;
  std::vector<double> final_rmse_per_trial;
  std::vector<double> final_bound_per_trial;    ///< each trial's own bound at its final step
  std::vector<double> final_optimum_per_trial;  ///< the optimum of each trial's own data at its final step
  /// Agents the self-check flags at the final step (docs/algorithms.md §1.6).
  std::vector<int> final_flagged_per_trial;
  /// Steps at which some agent's estimate was NaN or Inf, per trial (run_record.hpp NonFiniteEstimates).
  std::vector<std::size_t> non_finite_steps_per_trial;
  rundir::RunRecord first_trial;  ///< trial 0 in full (estimates, links) for the run directory
  int trials = 0;
  int threads = 0;
  double wall_s = 0.0;
};

/// Runs `trials` independent trials of `scenario` on `threads` threads (0 = every core). The
/// configuration is fixed by the seed; noise, initial guesses and loss differ per trial.
/// `on_record`, if set, is called from the worker thread with every trial's full record (estimates
/// included); it must only touch per-trial state. `cancel` (Ctrl-C), polled per agent: once set, the
/// trials stop and run_monte_carlo throws Cancelled.
MonteCarloResult run_monte_carlo(
    const config::Scenario& scenario, int trials, int threads = 0,
    const std::function<void(int done, int total)>& on_trial = {},
    const std::function<void(int trial, const rundir::RunRecord&)>& on_record = {},
    const std::atomic<bool>* cancel = nullptr);

/// Writes montecarlo.csv (per-step mean and spread) and trials.csv into `directory`.
void write_monte_carlo(const std::filesystem::path& directory, const MonteCarloResult& result);

/// Fills record.links and record.agent_summaries from the runtimes at the end of an in-process run.
void record_agents(rundir::RunRecord& record, const world::World& world,
                   const std::vector<const runtime::AgentRuntime*>& agents);

}  // namespace swarmloc::sim
