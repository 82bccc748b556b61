#include "swarmloc/sim/simulator.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <mutex>
#include <numbers>
#include <sstream>
#include <thread>

#include "swarmloc/run/manifests.hpp"
#include "swarmloc/runtime/agent_factory.hpp"
#include "swarmloc/runtime/agent_runtime.hpp"
#include "swarmloc/runtime/hostile.hpp"
#include "swarmloc/runtime/process_cpu.hpp"
#include "swarmloc/sim/centralized_runner.hpp"

namespace swarmloc::sim {

void record_agents(rundir::RunRecord& record, const world::World& world,
                   const std::vector<const runtime::AgentRuntime*>& agents) {
  // Inserted in key order (sender, receiver), each at the end: linear, where inserting receiver by
  // receiver searched the tree for every one of the 10^6–10^7 links of a 10^5-agent run.
  std::vector<std::pair<std::pair<AgentId, AgentId>, runtime::LinkCounters>> links;
  for (AgentId i = 0; i < world.size(); ++i) {
    for (const auto& [sender, counters] : agents[static_cast<std::size_t>(i)]->links())
      links.push_back({{sender, i}, counters});
  }
  std::sort(links.begin(), links.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [key, counters] : links) record.links.insert_or_assign(record.links.end(), key, counters);
  for (AgentId i = 0; i < world.size(); ++i) {
    const auto& agent = *agents[static_cast<std::size_t>(i)];
    rundir::AgentSummary summary;
    summary.agent = i;
    summary.anchor = world.is_anchor[static_cast<std::size_t>(i)];
    summary.steps_run = static_cast<std::uint32_t>(agent.steps_run());
    summary.samples_published = agent.samples_published();
    summary.samples_published_in_steps = agent.samples_published_in_steps();
    summary.rejected_by_reason = agent.rejected_by_reason();
    record.agent_summaries.push_back(summary);
  }
}

namespace {

/// fn(i) for every agent i in [0, n) on `threads` threads (contiguous blocks); serial for threads ≤ 1.
/// Every thread stops at the next agent once control's flag is set; then, all joined, this throws
/// Cancelled. The calling thread reports its own block's progress to `phase`.
template <typename Fn>
void for_each_agent(int n, int threads, const world::WorkControl& control, world::WorkPhase& phase, Fn&& fn) {
  auto run = [&](AgentId from, AgentId to, bool report) {
    for (AgentId i = from; i < to && !control.cancelled(); ++i) {
      if (report) phase.report(static_cast<std::size_t>(i - from), static_cast<std::size_t>(to - from));
      fn(i);
    }
  };
  if (threads <= 1 || n < 2 * threads) {
    run(0, n, true);
  } else {
    std::vector<std::thread> pool;
    pool.reserve(static_cast<std::size_t>(threads - 1));
    const int block = (n + threads - 1) / threads;
    for (int t = 1; t < threads; ++t)
      pool.emplace_back([&, t] { run(t * block, std::min(n, (t + 1) * block), false); });
    run(0, std::min(n, block), true);
    for (auto& thread : pool) thread.join();
  }
  control.throw_if_cancelled();
}

}  // namespace

int auto_round_threads(int agents) {
  if (agents < kParallelRoundsFromAgents) return 1;
  return static_cast<int>(std::max(1U, std::thread::hardware_concurrency()));
}

rundir::RunRecord run_simulation(const config::Scenario& scenario, const SimOptions& options) {
  if (scenario.run.sim_clock == config::SimClock::kAgents)
    return run_agent_clock_simulation(scenario, options);
  if (config::runs_in_fusion_centre(scenario.algorithm.name))
    return run_centralized_simulation(scenario, options);
  return run_simulation(scenario, world::build_world(scenario, options.trial, -1, options.control), options);
}

namespace {

/// Whether one of `faults` holds `agent` down at `step`.
bool within(const std::vector<config::AgentFault>& faults, AgentId agent, std::int64_t step) {
  return std::any_of(faults.begin(), faults.end(), [&](const config::AgentFault& f) {
    return f.agent == agent && step >= f.from_step && (f.to_step < 0 || step < f.to_step);
  });
}

/// One lockstep run over a built world: every agent's runtime, what each published last round, the
/// faults, and the per-step scoring into a RunRecord.
class LockstepSimulation {
 public:
  LockstepSimulation(const config::Scenario& scenario, world::World& world, const SimOptions& options)
      : scenario_(scenario),
        world_(world),
        options_(options),
        control_(options.control),
        n_(world.size()),
        period_s_(1.0 / scenario.run.rate_hz),
        step_phase_(options.control, "") {}

  /// The agents, the record's header, the first publications, the faults and the links.
  void set_up(rundir::RunRecord& record);
  /// The world steps, until run.steps or Ctrl-C.
  void run_steps(rundir::RunRecord& record);
  [[nodiscard]] const std::vector<runtime::AgentRuntime>& agents() const { return agents_; }

 private:
  [[nodiscard]] std::int64_t stamp_ns(std::int64_t step) const {
    return static_cast<std::int64_t>(static_cast<double>(step) * period_s_ * 1e9);
  }
  void create_agents();
  void index_incoming();
  void run_step(std::int64_t step, rundir::RunRecord& record);
  void restart_killed(std::int64_t step);
  void deliver_previous_round(std::int64_t step, std::int64_t delivered_ns);
  void step_agent_with_batch(AgentId i, std::int64_t step);
  void run_extra_rounds(std::int64_t step);
  void run_quiet_round(std::int64_t step, std::int64_t round_ns);
  void settle(rundir::RunRecord& record);
  void score_step(std::int64_t step, rundir::RunRecord& record, bool report = true);

  const config::Scenario& scenario_;
  world::World& world_;
  const SimOptions& options_;
  const world::WorkControl& control_;
  const int n_;
  const double period_s_;
  runtime::AgentManifest shared_manifest_;  ///< what every agent is told alike (run/manifests.hpp)
  std::vector<runtime::AgentRuntime> agents_;
  std::vector<runtime::AgentRuntime::Publication> published_;
  std::vector<config::AgentFault> kills_;
  std::vector<config::AgentFault> pauses_;
  std::vector<int> incarnation_;
  std::vector<std::optional<estimators::Estimate>> estimates_;
  std::vector<estimators::MeasurementBatch> batches_;
  // incoming[r]: the agents whose samples reach r, ascending (the order a serial sender loop delivers in).
  std::vector<std::vector<AgentId>> incoming_;
  int threads_ = 1;
  double agents_cpu_s_ = 0.0;  ///< this thread's CPU in the agents' receiving and stepping (run_step)
  std::int64_t world_steps_run_ = 0;
  // A step of a large world takes seconds (a dense one: minutes), so the rounds report their progress and
  // stop at the next agent on Ctrl-C; the step cut short is not scored.
  world::WorkPhase step_phase_;
};

void LockstepSimulation::create_agents() {
  agents_.reserve(static_cast<std::size_t>(n_));
  shared_manifest_ = run::shared_manifest(scenario_, world_, options_.trial);
  world::WorkPhase phase(control_, "agents: creating " + std::to_string(n_) + " agents");
  for (AgentId i = 0; i < n_; ++i) {
    phase.tick(static_cast<std::size_t>(i), static_cast<std::size_t>(n_));
    agents_.push_back(
        runtime::make_agent_runtime(scenario_, run::agent_manifest(shared_manifest_, world_, i)));
  }
}

void LockstepSimulation::index_incoming() {
  incoming_.resize(static_cast<std::size_t>(n_));
  world::WorkPhase phase(control_, "agents: links");
  for (AgentId sender = 0; sender < n_; ++sender) {
    phase.tick(static_cast<std::size_t>(sender), static_cast<std::size_t>(n_));
    for (AgentId receiver : world_.neighbours[static_cast<std::size_t>(sender)])
      incoming_[static_cast<std::size_t>(receiver)].push_back(sender);
  }
}

void LockstepSimulation::set_up(rundir::RunRecord& record) {
  create_agents();
  record.scenario = scenario_;
  record.mode = "sim";
  record.agents = n_;
  record.anchors = world_.anchor_count();
  record.mean_degree = world_.mean_degree();
  rundir::compute_run_bounds(record, world_);
  record.processes = 1;

  published_.resize(static_cast<std::size_t>(n_));
  for (AgentId i = 0; i < n_; ++i)
    published_[static_cast<std::size_t>(i)] = agents_[static_cast<std::size_t>(i)].initial_publication(0);

  // faults.kill / faults.pause: a dead agent neither receives, steps nor publishes and is rebuilt with
  // fresh state at its restart; a paused one keeps receiving (its reader cache) but does not step.
  kills_ = config::parse_agent_faults(scenario_.faults.kill, "faults.kill", false);
  pauses_ = config::parse_agent_faults(scenario_.faults.pause, "faults.pause", true);
  incarnation_.assign(static_cast<std::size_t>(n_), 0);

  estimates_.resize(static_cast<std::size_t>(n_));
  batches_.resize(static_cast<std::size_t>(n_));
  index_incoming();
  threads_ = options_.round_threads == 0 ? auto_round_threads(n_) : options_.round_threads;
  if (options_.recorder != nullptr || world_.recorded) threads_ = 1;  // ordered side effects
  control_.throw_if_cancelled();
  if (options_.recorder) options_.recorder->begin(scenario_, world_);
}

void LockstepSimulation::run_steps(rundir::RunRecord& record) {
  for (std::int64_t step = 0; step < scenario_.run.steps; ++step) {
    if (control_.cancelled()) {
      record.interrupted = true;
      break;
    }
    step_phase_.restart("step " + std::to_string(step + 1) + "/" + std::to_string(scenario_.run.steps));
    try {
      run_step(step, record);
    } catch (const world::Cancelled&) {
      record.interrupted = true;
      break;
    }
  }
  if (threads_ == 1 && world_steps_run_ > 0) {
    // Per agent and world step (the settle's quiet rounds not included): flat in N when every agent's work
    // is neighbour-scoped (docs/scale.md, "Per-agent cost against N in the simulator").
    record.extra["agents_cpu"] = {
        {"us_per_agent_per_world_step",
         agents_cpu_s_ * 1e6 / (static_cast<double>(n_) * static_cast<double>(world_steps_run_))},
        {"world_steps", world_steps_run_}};
  }
  if (!record.interrupted && !record.metrics.empty()) {
    try {
      settle(record);
    } catch (const world::Cancelled&) {
      record.interrupted = true;  // the last step keeps its score before the settle
    }
  }
}

void LockstepSimulation::run_step(std::int64_t step, rundir::RunRecord& record) {
  if (step > 0) world::advance_truth(world_, scenario_, step);
  restart_killed(step);
  // Deliver round k−1's samples over the lossy bus, then the world-step-k batches. Each receiver takes
  // its senders in ascending id order, so its mailbox and loss draws do not depend on the threads.
  // The agents' own CPU (receiving, stepping, publishing), without the world's: with one thread per round
  // it is this thread's (summary.json agents_cpu).
  const double delivering = runtime::thread_cpu_s();
  deliver_previous_round(step, stamp_ns(step));
  agents_cpu_s_ += runtime::thread_cpu_s() - delivering;
  for_each_agent(n_, threads_, control_, step_phase_, [&](AgentId i) {
    batches_[static_cast<std::size_t>(i)] = world::generate_batch(world_, scenario_, i, step);
  });
  if (options_.recorder) options_.recorder->world_step(step, world_.truth, batches_);
  rundir::observe_world_step(record, step, world_, batches_);
  const double stepping = runtime::thread_cpu_s();
  for_each_agent(n_, threads_, control_, step_phase_, [&](AgentId i) { step_agent_with_batch(i, step); });
  run_extra_rounds(step);
  agents_cpu_s_ += runtime::thread_cpu_s() - stepping;
  ++world_steps_run_;
  score_step(step, record);
}

void LockstepSimulation::restart_killed(std::int64_t step) {
  for (const auto& fault : kills_) {
    if (fault.to_step != step) continue;
    const auto k = static_cast<std::size_t>(fault.agent);
    agents_[k] = runtime::make_agent_runtime(
        scenario_, run::agent_manifest(shared_manifest_, world_, fault.agent), ++incarnation_[k]);
  }
}

void LockstepSimulation::deliver_previous_round(std::int64_t step, std::int64_t delivered_ns) {
  for_each_agent(n_, threads_, control_, step_phase_, [&](AgentId receiver) {
    if (within(kills_, receiver, step)) return;
    auto& agent = agents_[static_cast<std::size_t>(receiver)];
    for (AgentId sender : incoming_[static_cast<std::size_t>(receiver)]) {
      const auto& publication = published_[static_cast<std::size_t>(sender)];
      runtime::AgentRuntime::for_each_sample(
          publication, [&](const runtime::Header& header, const auto& message) {
            if (options_.recorder) {
              // Published in the previous round, delivered in this one (virtual world time).
              options_.recorder->sample(
                  runtime::ReceivedSample{receiver, agent.steps_run(), publication.header.sender_stamp_ns,
                                          delivered_ns, true, header, runtime::SampleMessage(message)});
            }
            agent.on_sample(header, message);
          });
    }
  });
}

/// Agent i takes its world-step batch, then steps and publishes (unless down or restarted just now).
void LockstepSimulation::step_agent_with_batch(AgentId i, std::int64_t step) {
  const auto k = static_cast<std::size_t>(i);
  runtime::Header header{kOrchestratorId, static_cast<std::uint32_t>(step), step, stamp_ns(step),
                         stamp_ns(step)};
  agents_[k].on_batch(header, std::move(batches_[k]));
  if (within(kills_, i, step) || within(pauses_, i, step)) {
    published_[k] = runtime::AgentRuntime::Publication{};  // publishes nothing this round
    estimates_[k].reset();                                 // not scored while down
    return;
  }
  const bool restarted_now = std::any_of(kills_.begin(), kills_.end(), [&](const config::AgentFault& f) {
    return f.agent == i && f.to_step == step;
  });
  if (restarted_now) {
    // A restarted process announces its prior first; its neighbours use it from the next round.
    published_[k] = agents_[k].initial_publication(stamp_ns(step));
    estimates_[k].reset();
    return;
  }
  published_[k] = agents_[k].step(stamp_ns(step));
  runtime::make_hostile_if_listed(options_.hostile_agents, i, published_[k].outbox,
                                  published_[k].header.step);
  estimates_[k] = agents_[k].estimate();
}

/// run.agent_steps_per_world_step: further exchanges within the period, without a batch.
void LockstepSimulation::run_extra_rounds(std::int64_t step) {
  for (int round = 1; round < scenario_.run.agent_steps_per_world_step; ++round) {
    run_quiet_round(step, stamp_ns(step) + (stamp_ns(step + 1) - stamp_ns(step)) * round /
                                               scenario_.run.agent_steps_per_world_step);
  }
}

/// One exchange without a batch: deliver the previous round's samples, step, publish.
void LockstepSimulation::run_quiet_round(std::int64_t step, std::int64_t round_ns) {
  deliver_previous_round(step, round_ns);
  for_each_agent(n_, threads_, control_, step_phase_, [&](AgentId i) {
    const auto k = static_cast<std::size_t>(i);
    if (within(kills_, i, step) || within(pauses_, i, step)) return;
    published_[k] = agents_[k].step(round_ns);
    runtime::make_hostile_if_listed(options_.hostile_agents, i, published_[k].outbox,
                                    published_[k].header.step);
    estimates_[k] = agents_[k].estimate();
  });
}

/// Free run: the DDS orchestrator keeps collecting estimates for run.settle_s after the last world step
/// while the agents keep ticking on no new data, then re-scores the last step; so do these rounds.
/// Lockstep DDS agents step only on batches: none there.
void LockstepSimulation::settle(rundir::RunRecord& record) {
  const auto rounds = settle_rounds(scenario_);
  if (rounds <= 0) return;
  const std::int64_t last = record.metrics.back().step;
  const std::int64_t round_period_ns =
      (stamp_ns(last + 1) - stamp_ns(last)) / scenario_.run.agent_steps_per_world_step;
  step_phase_.restart("settling");
  for (std::int64_t round = 0; round < rounds; ++round)
    run_quiet_round(last, stamp_ns(last + 1) + round * round_period_ns);
  record.metrics.pop_back();
  while (!record.estimates.empty() && record.estimates.back().step == last) record.estimates.pop_back();
  score_step(last, record, false);
}

void LockstepSimulation::score_step(std::int64_t step, rundir::RunRecord& record, bool report) {
  rundir::StepMetrics metrics;
  metrics.step = step;
  metrics.time_s = world::reported_time_s(scenario_, step);
  metrics.errors = world::score(world_, estimates_);
  rundir::note_scored_estimates(record, estimates_);
  rundir::set_step_bounds(record, metrics);
  record.metrics.push_back(metrics);
  if (options_.record_estimates) {
    for (AgentId i = 0; i < n_; ++i) {
      if (!estimates_[static_cast<std::size_t>(i)]) continue;  // down (faults)
      record.estimates.push_back({step, i, *estimates_[static_cast<std::size_t>(i)], world_.scored_truth(i),
                                  world_.scored_truth_z(i)});
    }
  }
  if (report && options_.on_step) options_.on_step(step, metrics.errors);
}

}  // namespace

std::int64_t settle_rounds(const config::Scenario& scenario) {
  if (scenario.run.mode != config::RunMode::kFreeRun) return 0;
  return std::llround(scenario.run.settle_s * scenario.run.rate_hz * scenario.run.agent_steps_per_world_step);
}

rundir::RunRecord run_simulation(const config::Scenario& scenario, world::World world,
                                 const SimOptions& options) {
  if (scenario.run.sim_clock == config::SimClock::kAgents)
    return run_agent_clock_simulation(scenario, options);
  if (config::runs_in_fusion_centre(scenario.algorithm.name))
    return run_centralized_simulation(scenario, options);
  const auto started = std::chrono::steady_clock::now();
  world::attach_recorded(world, options.recorded);
  LockstepSimulation simulation(scenario, world, options);
  rundir::RunRecord record;
  simulation.set_up(record);
  simulation.run_steps(record);
  rundir::update_run_optimum(record, true);
  std::vector<const runtime::AgentRuntime*> runtimes;
  runtimes.reserve(simulation.agents().size());
  for (const auto& agent : simulation.agents()) runtimes.push_back(&agent);
  record_agents(record, world, runtimes);
  record.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return record;
}

namespace {

/// Per trial, per step: (mse, rmse, nees), the squared bounds and optimum, and the final figures. Trials are
/// independent, so threads share nothing but an index.
struct TrialSeries {
  explicit TrialSeries(int trials)
      : per_trial(static_cast<std::size_t>(trials)),
        per_trial_bound(static_cast<std::size_t>(trials)),
        final_rmse(static_cast<std::size_t>(trials), 0.0),
        final_bound(static_cast<std::size_t>(trials), 0.0),
        final_optimum(static_cast<std::size_t>(trials), 0.0),
        final_flagged(static_cast<std::size_t>(trials), 0),
        non_finite_steps(static_cast<std::size_t>(trials), 0) {}
  // Per trial, per step: (mse, rmse, nees).
  std::vector<std::vector<std::array<double, 3>>> per_trial;
  // Per trial, per step: the squared bound, all-data bound and optimum (NaN when the run has none, and the
  // optimum off its checkpoints).
  std::vector<std::vector<std::array<double, 3>>> per_trial_bound;
  std::vector<double> final_rmse;
  std::vector<double> final_bound;
  std::vector<double> final_optimum;
  std::vector<int> final_flagged;
  std::vector<std::size_t> non_finite_steps;

  /// Trial t's rows, from its record.
  void add(int t, const rundir::RunRecord& record, std::size_t steps) {
    const auto k = static_cast<std::size_t>(t);
    auto& rows = per_trial[k];
    rows.reserve(steps);
    for (const auto& m : record.metrics) {
      rows.push_back({m.errors.rmse_m * m.errors.rmse_m, m.errors.rmse_m, m.errors.nees});
      per_trial_bound[k].push_back({m.bound_rmse_m * m.bound_rmse_m,
                                    m.bound_all_data_rmse_m * m.bound_all_data_rmse_m,
                                    m.optimum_rmse_m * m.optimum_rmse_m});
    }
    const rundir::StepMetrics& last = *record.final_metrics();
    final_rmse[k] = last.errors.rmse_m;
    final_bound[k] = last.bound_rmse_m;
    final_optimum[k] = last.optimum_rmse_m;
    final_flagged[k] = last.errors.flagged;
    non_finite_steps[k] = rundir::non_finite_estimates(record).steps;
  }
};

/// Step k's mean and spread over the trials; the CRLB is the first trial's.
MonteCarloStep aggregate_step(std::size_t k, int trials, const TrialSeries& series,
                              const std::vector<rundir::StepMetrics>& reference) {
  MonteCarloStep row;
  row.step = static_cast<std::int64_t>(k);
  row.crlb_rmse_m = k < reference.size() ? reference[k].crlb_rmse_m : 0.0;
  std::array<double, 3> bound_sum{};
  for (const auto& trial_rows : series.per_trial_bound) {
    for (std::size_t q = 0; q < 3; ++q) bound_sum[q] += trial_rows[k][q];
  }
  row.bound_rmse_m = std::sqrt(bound_sum[0] / static_cast<double>(trials));
  row.bound_all_data_rmse_m = std::sqrt(bound_sum[1] / static_cast<double>(trials));
  row.optimum_rmse_m = std::sqrt(bound_sum[2] / static_cast<double>(trials));
  std::array<double, 3> sum{}, sum_sq{};
  for (const auto& trial_rows : series.per_trial) {
    for (std::size_t q = 0; q < 3; ++q) {
      sum[q] += trial_rows[k][q];
      sum_sq[q] += trial_rows[k][q] * trial_rows[k][q];
    }
  }
  const double n = static_cast<double>(trials);
  auto spread = [&](std::size_t q) {
    return std::sqrt(std::max(0.0, sum_sq[q] / n - (sum[q] / n) * (sum[q] / n)));
  };
  row.mse_mean = sum[0] / n, row.mse_std = spread(0);
  row.rmse_mean = sum[1] / n, row.rmse_std = spread(1);
  row.nees_mean = sum[2] / n, row.nees_std = spread(2);
  return row;
}

}  // namespace

MonteCarloResult run_monte_carlo(const config::Scenario& scenario, int trials, int threads,
                                 const std::function<void(int, int)>& on_trial,
                                 const std::function<void(int, const rundir::RunRecord&)>& on_record,
                                 const std::atomic<bool>* cancel) {
  require_supported_sim_clock(scenario);  // here, not in a worker thread, where it would terminate
  const auto started = std::chrono::steady_clock::now();
  MonteCarloResult result;
  result.trials = trials;
  result.threads =
      threads > 0 ? threads : static_cast<int>(std::max(1U, std::thread::hardware_concurrency()));
  const auto steps = static_cast<std::size_t>(scenario.run.steps);
  TrialSeries series(trials);
  std::atomic<int> next{0};
  std::atomic<int> done{0};
  std::mutex progress_mutex;
  const world::WorkControl control{cancel, {}};
  auto worker = [&] {
    for (int t = next++; t < trials && !control.cancelled(); t = next++) {
      SimOptions options;
      options.trial = static_cast<std::uint64_t>(t);
      options.record_estimates = (t == 0) || static_cast<bool>(on_record);
      options.control = control;
      rundir::RunRecord record;
      try {
        record = run_simulation(scenario, options);
      } catch (const world::Cancelled&) {
        return;  // an exception must not leave a worker thread
      }
      if (record.interrupted) return;
      if (on_record) on_record(t, record);
      series.add(t, record, steps);
      if (t == 0) result.first_trial = std::move(record);
      const int finished = ++done;
      if (on_trial) {
        const std::lock_guard<std::mutex> lock(progress_mutex);
        on_trial(finished, trials);
      }
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(static_cast<std::size_t>(result.threads));
  for (int k = 0; k < result.threads; ++k) pool.emplace_back(worker);
  for (auto& thread : pool) thread.join();
  control.throw_if_cancelled();

  for (std::size_t k = 0; k < steps; ++k)
    result.steps.push_back(aggregate_step(k, trials, series, result.first_trial.metrics));
  result.final_rmse_per_trial = std::move(series.final_rmse);
  result.final_bound_per_trial = std::move(series.final_bound);
  result.final_optimum_per_trial = std::move(series.final_optimum);
  result.final_flagged_per_trial = std::move(series.final_flagged);
  result.non_finite_steps_per_trial = std::move(series.non_finite_steps);
  result.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return result;
}

void write_monte_carlo(const std::filesystem::path& directory, const MonteCarloResult& result) {
  rundir::create_output_directories(directory);
  std::ostringstream out;
  out << "step,mse_mean_m2,mse_std_m2,rmse_mean_m,rmse_std_m,nees_mean,nees_std,crlb_rmse_m,bound_rmse_m,"
         "bound_all_data_rmse_m,optimum_rmse_m\n"
      << std::setprecision(9);
  for (const auto& r : result.steps) {
    out << r.step << ',' << r.mse_mean << ',' << r.mse_std << ',' << r.rmse_mean << ',' << r.rmse_std << ','
        << r.nees_mean << ',' << r.nees_std << ',' << r.crlb_rmse_m << ',' << r.bound_rmse_m << ','
        << r.bound_all_data_rmse_m << ',' << r.optimum_rmse_m << '\n';
  }
  runtime::write_text_file(directory / "montecarlo.csv", out.str());
  std::ostringstream trials;
  // The bound and the optimum of each trial's own data come last (docs/algorithms.md §1.3.1, §1.3.2).
  trials << "trial,final_rmse_m,flagged_agents,non_finite_steps,bound_rmse_m,bound_ratio,optimum_rmse_m,"
            "efficiency\n"
         << std::setprecision(9);
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  auto at = [](const std::vector<double>& values, std::size_t t) {
    return t < values.size() ? values[t] : kNaN;
  };
  for (std::size_t t = 0; t < result.final_rmse_per_trial.size(); ++t) {
    const double rmse = result.final_rmse_per_trial[t];
    const double bound = at(result.final_bound_per_trial, t);
    const double optimum = at(result.final_optimum_per_trial, t);
    trials << t << ',' << rmse << ','
           << (t < result.final_flagged_per_trial.size() ? result.final_flagged_per_trial[t] : 0) << ','
           << (t < result.non_finite_steps_per_trial.size() ? result.non_finite_steps_per_trial[t] : 0) << ','
           << bound << ',' << rmse / bound << ',' << optimum << ',' << rmse / optimum << '\n';
  }
  runtime::write_text_file(directory / "trials.csv", trials.str());
}

}  // namespace swarmloc::sim
