// run.sim_clock = agents: the simulator as a deterministic discrete-event simulation on virtual time.
// The orchestrator publishes world step k's batches at t = k·T; agent i ticks on its own drifting clock
// as the DDS agent does; every sample and batch reaches its receiver after a seeded latency.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <queue>
#include <variant>

#include "swarmloc/core/random.hpp"
#include "swarmloc/runtime/agent_factory.hpp"
#include "swarmloc/runtime/hostile.hpp"
#include "swarmloc/sim/centralized_runner.hpp"
#include "swarmloc/sim/simulator.hpp"

namespace swarmloc::sim {
namespace {

/// What happens first among events at the same virtual instant. Ticks at one instant are simultaneous
/// (none sees another's sample of that instant); the interval that ends at t is scored after the
/// ticks at t and before the world moves on to the next step at t.
enum class Phase : int {
  kArrival = 0,      ///< a sample or batch sent before t reaches its receiver
  kTick = 1,         ///< an agent's clock period elapsed: it steps and publishes
  kScore = 2,        ///< the interval of world step k ends (t = (k+1)·T)
  kWorldStep = 3,    ///< faults, truth advance and batch publication of world step k (t = k·T)
  kSameInstant = 4,  ///< a zero-latency arrival: after everything else at its sending instant
};

struct SampleArrival {
  AgentId receiver = 0;
  double sent_s = 0.0;  ///< virtual time of the publication (--record)
  std::shared_ptr<const AgentRuntime::Publication> publication;  ///< shared by every receiver
};
struct BatchArrival {
  AgentId receiver = 0;
  std::int64_t step = 0;
  std::shared_ptr<const estimators::MeasurementBatch> batch;
};
struct Tick {
  AgentId agent = 0;
  int incarnation = 0;     ///< a tick of a killed incarnation is dropped
  std::int64_t index = 1;  ///< the m-th tick of this incarnation's timer
};
struct ScoreStep {
  std::int64_t step = 0;
  bool settled = false;  ///< the re-score of the last step after run.settle_s (free run)
};
struct WorldStep {
  std::int64_t step = 0;
};

struct Event {
  double time_s = 0.0;
  Phase phase = Phase::kArrival;
  std::uint64_t order = 0;  ///< insertion counter: the last tie-break, so equal keys keep FIFO order
  std::variant<SampleArrival, BatchArrival, Tick, ScoreStep, WorldStep> what;
};
struct Later {
  bool operator()(const Event& a, const Event& b) const {
    if (a.time_s != b.time_s) return a.time_s > b.time_s;
    if (a.phase != b.phase) return a.phase > b.phase;
    return a.order > b.order;
  }
};

World make_world(const config::Scenario& scenario, const SimOptions& options) {
  World world = build_world(scenario, options.trial);
  attach_recorded(world, options.recorded);
  return world;
}

/// Virtual time in integer nanoseconds (the simulator's stamps in --record sample logs).
std::int64_t virtual_ns(double time_s) { return static_cast<std::int64_t>(std::llround(time_s * 1e9)); }

class AgentClockSimulation {
 public:
  AgentClockSimulation(const config::Scenario& scenario, const SimOptions& options)
      : scenario_(scenario),
        options_(options),
        world_(make_world(scenario, options)),
        period_s_(1.0 / scenario.run.rate_hz),
        latency_seed_(trial_seed(scenario.seed, options.trial)),
        kills_(config::parse_agent_faults(scenario.faults.kill, "faults.kill", false)),
        pauses_(config::parse_agent_faults(scenario.faults.pause, "faults.pause", true)) {
    const auto n = static_cast<std::size_t>(world_.size());
    agents_.reserve(n);
    for (AgentId i = 0; i < world_.size(); ++i) {
      agents_.emplace_back(make_agent_estimator(scenario, world_, i), world_.setup_of(i),
                           world_.neighbours[static_cast<std::size_t>(i)],
                           make_runtime_params(scenario, world_, options.trial));
    }
    incarnation_.assign(n, 0);
    dead_.assign(n, false);
    paused_.assign(n, false);
    timer_start_s_.assign(n, 0.0);
  }

  RunRecord run() {
    const auto started = std::chrono::steady_clock::now();
    RunRecord record;
    record.scenario = scenario_;
    record.mode = "sim";
    record.agents = world_.size();
    record.anchors = world_.anchor_count();
    record.mean_degree = world_.mean_degree();
    compute_run_bounds(record, world_);
    record.processes = 1;
    record.extra["sim_clock"] = "agents";
    record.extra["network_delay_ms"] = scenario_.network.delay_ms;
    record.extra["network_jitter_ms"] = scenario_.network.jitter_ms;
    if (options_.recorder) options_.recorder->begin(scenario_, world_);

    // As over DDS: every agent announces its prior before the run starts, and its timer starts with
    // the run (START), whatever its clock reads; the first tick comes one local period later.
    for (AgentId i = 0; i < world_.size(); ++i) {
      publish(i, agent(i).initial_publication(local_stamp_ns(i, 0.0)), 0.0);
      schedule_tick(i, 1);
    }
    for (std::int64_t step = 0; step < scenario_.run.steps; ++step) {
      push(world_time(step), Phase::kWorldStep, WorldStep{step});
      push(world_time(step + 1), Phase::kScore, ScoreStep{step});
    }
    // Free run: the orchestrator's settle (settle_rounds), the agents ticking on with no new batch.
    finished_ = scenario_.run.steps <= 0;
    if (const auto rounds = settle_rounds(scenario_); rounds > 0 && !finished_) {
      // At the instant of the last settle tick of a drift-free clock (the same product as its tick time),
      // so that tick is in the final score.
      const int per_step = scenario_.run.agent_steps_per_world_step;
      push(static_cast<double>(scenario_.run.steps * per_step + rounds) * (period_s_ / per_step),
           Phase::kScore, ScoreStep{scenario_.run.steps - 1, true});
    }
    // The run ends when its last interval is scored: what happens after that instant's ticks is unseen.
    while (!queue_.empty() && !finished_) {
      const Event event = queue_.top();
      queue_.pop();
      now_s_ = event.time_s;
      std::visit([&](const auto& what) { handle(what, record); }, event.what);
    }

    update_run_optimum(record, true);
    record_agents(record, world_, agents_);
    record.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    return record;
  }

 private:
  AgentRuntime& agent(AgentId id) { return agents_[static_cast<std::size_t>(id)]; }
  [[nodiscard]] double world_time(std::int64_t step) const { return static_cast<double>(step) * period_s_; }

  void push(double time_s, Phase phase, decltype(Event::what) what) {
    queue_.push(Event{time_s, phase, next_order_++, std::move(what)});
  }

  /// The agent's clock reading at virtual time t (ClockModel, the seeded draw the DDS agent uses).
  [[nodiscard]] std::int64_t local_stamp_ns(AgentId id, double time_s) const {
    return static_cast<std::int64_t>(
        std::llround(world_.clocks[static_cast<std::size_t>(id)].local_time(time_s) * 1e9));
  }

  /// Tick m of the agent's current timer: its phase plus m local periods after the timer started, i.e.
  /// (φ_i + m)·T/(1+drift) of virtual time (T: the world period over run.agent_steps_per_world_step;
  /// φ_i: tick_phase_fraction, as the DDS agent). Computed from m (not accumulated), so a drift-free
  /// aligned clock ticks exactly at m·T.
  void schedule_tick(AgentId id, std::int64_t index) {
    const auto k = static_cast<std::size_t>(id);
    const double tick_period_s =
        world_.clocks[k].mono_duration(period_s_ / scenario_.run.agent_steps_per_world_step);
    const double phase = tick_phase_fraction(scenario_, id);
    push(timer_start_s_[k] + (phase + static_cast<double>(index)) * tick_period_s, Phase::kTick,
         Tick{id, incarnation_[k], index});
  }

  /// Latency of one delivery: delay + U[0, jitter), seeded per (sender, receiver, what). Each
  /// publication draws once per receiver, so the samples of one step travel together.
  [[nodiscard]] double latency_s(AgentId sender, AgentId receiver, std::uint64_t kind,
                                 std::int64_t key) const {
    const double jitter_ms = scenario_.network.jitter_ms > 0.0
                                 ? scenario_.network.jitter_ms *
                                       core::unit_uniform(core::hash_keys(
                                           latency_seed_, static_cast<std::uint64_t>(core::Stream::kDelay),
                                           sender, receiver, kind, key))
                                 : 0.0;
    return (scenario_.network.delay_ms + jitter_ms) * 1e-3;
  }

  /// An arrival at the sending instant itself (zero latency) waits until every tick of that instant
  /// has run, so simultaneous ticks stay simultaneous (the same inputs as in rounds).
  void push_arrival(double sent_s, double latency, decltype(Event::what) what) {
    const double arrives_s = sent_s + latency;
    push(arrives_s, arrives_s > sent_s ? Phase::kArrival : Phase::kSameInstant, std::move(what));
  }

  void publish(AgentId sender, AgentRuntime::Publication publication, double sent_s) {
    auto shared = std::make_shared<const AgentRuntime::Publication>(std::move(publication));
    constexpr std::uint64_t kSampleKind = 0;
    for (AgentId receiver : world_.neighbours[static_cast<std::size_t>(sender)]) {
      push_arrival(sent_s, latency_s(sender, receiver, kSampleKind, shared->header.seq),
                   SampleArrival{receiver, sent_s, shared});
    }
  }

  void handle(const SampleArrival& arrival, RunRecord& /*record*/) {
    // A dead process receives nothing; a paused one keeps its reader cache (as in rounds mode).
    if (dead_[static_cast<std::size_t>(arrival.receiver)]) return;
    auto& receiver = agent(arrival.receiver);
    AgentRuntime::for_each_sample(*arrival.publication, [&](const Header& header, const auto& message) {
      if (options_.recorder) {
        options_.recorder->sample(ReceivedSample{arrival.receiver, receiver.steps_run(),
                                                 virtual_ns(arrival.sent_s), virtual_ns(now_s_), true, header,
                                                 SampleMessage(message)});
      }
      receiver.on_sample(header, message);  // receiver-side loss, partition and ordering checks
    });
  }

  void handle(const BatchArrival& arrival, RunRecord& /*record*/) {
    if (dead_[static_cast<std::size_t>(arrival.receiver)]) return;
    const auto stamp = static_cast<std::int64_t>(static_cast<double>(arrival.step) * period_s_ * 1e9);
    const Header header{kOrchestratorId, static_cast<std::uint32_t>(arrival.step), arrival.step, stamp,
                        stamp};
    agent(arrival.receiver).on_batch(header, *arrival.batch);  // keeps only the newest, carries over
  }

  void handle(const Tick& tick, RunRecord& /*record*/) {
    const auto k = static_cast<std::size_t>(tick.agent);
    if (tick.incarnation != incarnation_[k] || dead_[k]) return;  // that process is gone
    schedule_tick(tick.agent, tick.index + 1);
    if (paused_[k]) return;  // SIGSTOP: the timer's periods pass without a step
    auto publication = agent(tick.agent).step(local_stamp_ns(tick.agent, now_s_));
    make_hostile_if_listed(options_.hostile_agents, tick.agent, publication.outbox, publication.header.step);
    publish(tick.agent, std::move(publication), now_s_);
  }

  void handle(const ScoreStep& score_step, RunRecord& record) {
    const bool last = score_step.step + 1 == scenario_.run.steps;
    finished_ = score_step.settled || (last && settle_rounds(scenario_) <= 0);
    if (score_step.settled) {
      record.metrics.pop_back();
      while (!record.estimates.empty() && record.estimates.back().step == score_step.step)
        record.estimates.pop_back();
    }
    const auto n = static_cast<std::size_t>(world_.size());
    // As the orchestrator: each agent's newest estimate, once it has stepped; not while down.
    std::vector<std::optional<estimators::Estimate>> estimates(n);
    for (std::size_t k = 0; k < n; ++k) {
      if (!dead_[k] && !paused_[k] && agents_[k].steps_run() > 0) estimates[k] = agents_[k].estimate();
    }
    StepMetrics metrics;
    metrics.step = score_step.step;
    metrics.time_s = world_time(score_step.step);
    metrics.errors = score(world_, estimates);
    set_step_bounds(record, metrics);
    record.metrics.push_back(metrics);
    if (options_.record_estimates) {
      for (std::size_t k = 0; k < n; ++k) {
        if (estimates[k])
          record.estimates.push_back({score_step.step, static_cast<AgentId>(k), *estimates[k],
                                      world_.scored_truth(static_cast<AgentId>(k))});
      }
    }
    if (options_.on_step && !score_step.settled) options_.on_step(score_step.step, metrics.errors);
  }

  void handle(const WorldStep& world_step, RunRecord& record) {
    const std::int64_t step = world_step.step;
    if (step > 0) advance_truth(world_, scenario_, step);
    apply_faults(step);
    constexpr std::uint64_t kBatchKind = 1;
    std::vector<estimators::MeasurementBatch> batches;
    batches.reserve(static_cast<std::size_t>(world_.size()));
    for (AgentId i = 0; i < world_.size(); ++i) batches.push_back(generate_batch(world_, scenario_, i, step));
    if (options_.recorder) options_.recorder->world_step(step, world_.truth, batches);
    observe_world_step(record, step, world_.truth, batches);
    for (AgentId i = 0; i < world_.size(); ++i) {
      auto batch = std::make_shared<const estimators::MeasurementBatch>(
          std::move(batches[static_cast<std::size_t>(i)]));
      push_arrival(now_s_, latency_s(kOrchestratorId, i, kBatchKind, step), BatchArrival{i, step, batch});
    }
  }

  /// faults.kill / faults.pause at world step `step`, as the orchestrator signals real processes: a
  /// killed agent stops at once; a restarted one is a fresh process that announces its prior and
  /// starts its timer then; a paused one keeps receiving but its ticks pass without a step.
  void apply_faults(std::int64_t step) {
    for (const auto& fault : kills_) {
      const auto k = static_cast<std::size_t>(fault.agent);
      if (fault.from_step == step) dead_[k] = true;
      if (fault.to_step == step) {
        ++incarnation_[k];
        agents_[k] = AgentRuntime(make_agent_estimator(scenario_, world_, fault.agent),
                                  world_.setup_of(fault.agent), world_.neighbours[k],
                                  make_runtime_params(scenario_, world_, options_.trial, incarnation_[k]));
        dead_[k] = false;
        timer_start_s_[k] = now_s_;
        publish(fault.agent, agents_[k].initial_publication(local_stamp_ns(fault.agent, now_s_)), now_s_);
        schedule_tick(fault.agent, 1);
      }
    }
    for (const auto& fault : pauses_) {
      const auto k = static_cast<std::size_t>(fault.agent);
      if (fault.from_step == step) paused_[k] = true;
      if (fault.to_step == step) paused_[k] = false;
    }
  }

  const config::Scenario& scenario_;
  const SimOptions& options_;
  World world_;
  double period_s_;
  std::uint64_t latency_seed_;
  std::vector<config::AgentFault> kills_;
  std::vector<config::AgentFault> pauses_;
  std::vector<AgentRuntime> agents_;
  std::vector<int> incarnation_;
  std::vector<bool> dead_;
  std::vector<bool> paused_;
  std::vector<double> timer_start_s_;  ///< virtual time the agent's current process started its timer
  std::priority_queue<Event, std::vector<Event>, Later> queue_;
  std::uint64_t next_order_ = 0;
  double now_s_ = 0.0;
  bool finished_ = false;  ///< the final score is taken
};

}  // namespace

void require_supported_sim_clock(const config::Scenario& scenario) {
  if (scenario.run.sim_clock == config::SimClock::kAgents &&
      config::runs_in_fusion_centre(scenario.algorithm.name)) {
    throw config::ScenarioError(
        "run.sim_clock: agents does not apply to algorithm.name = " + scenario.algorithm.name +
        " (a centralized filter runs in the fusion centre on whole world steps; "
        "use run.sim_clock = rounds)");
  }
}

RunRecord run_agent_clock_simulation(const config::Scenario& scenario, const SimOptions& options) {
  require_supported_sim_clock(scenario);
  return AgentClockSimulation(scenario, options).run();
}

}  // namespace swarmloc::sim
