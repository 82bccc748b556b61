// run.sim_clock = agents: the simulator as a deterministic discrete-event simulation on virtual time.
// The orchestrator publishes world step k's batches at t = k·T; agent i ticks on its own drifting clock
// by the same agent loop as the DDS agent (runtime/agent_loop.hpp); every sample and batch reaches its
// receiver after a seeded latency.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <queue>
#include <variant>

#include "swarmloc/core/random.hpp"
#include "swarmloc/run/manifests.hpp"
#include "swarmloc/runtime/agent_factory.hpp"
#include "swarmloc/runtime/agent_loop.hpp"
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
  std::shared_ptr<const runtime::AgentRuntime::Publication> publication;  ///< shared by every receiver
};
struct BatchArrival {
  AgentId receiver = 0;
  std::int64_t step = 0;
  std::shared_ptr<const estimators::MeasurementBatch> batch;
};
struct Tick {
  AgentId agent = 0;
  int incarnation = 0;  ///< a tick of a killed incarnation is dropped
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

world::World make_world(const config::Scenario& scenario, const SimOptions& options) {
  world::World world = world::build_world(scenario, options.trial);
  world::attach_recorded(world, options.recorded);
  return world;
}

/// Virtual time in integer nanoseconds (the simulator's stamps in --record sample logs).
std::int64_t virtual_ns(double time_s) { return static_cast<std::int64_t>(std::llround(time_s * 1e9)); }

class AgentClockSimulation;

/// An agent's outputs as deliveries on the simulated network (the simulator scores estimates itself, so
/// reports go nowhere).
class NetworkPort final : public runtime::AgentPort {
 public:
  NetworkPort(AgentClockSimulation& simulation, AgentId agent) : simulation_(simulation), agent_(agent) {}
  void publish(const runtime::AgentRuntime::Publication& publication) override;
  void report(const runtime::EstimateReport& /*report*/) override {}

 private:
  AgentClockSimulation& simulation_;
  AgentId agent_;
};

class AgentClockSimulation {
 public:
  AgentClockSimulation(const config::Scenario& scenario, const SimOptions& options)
      : scenario_(scenario),
        options_(options),
        world_(make_world(scenario, options)),
        period_s_(1.0 / scenario.run.rate_hz),
        latency_seed_(world::trial_seed(scenario.seed, options.trial)),
        kills_(config::parse_agent_faults(scenario.faults.kill, "faults.kill", false)),
        pauses_(config::parse_agent_faults(scenario.faults.pause, "faults.pause", true)),
        shared_manifest_(run::shared_manifest(scenario, world_, options.trial)) {
    const auto n = static_cast<std::size_t>(world_.size());
    ports_.reserve(n);
    loops_.resize(n);
    for (AgentId i = 0; i < world_.size(); ++i) {
      ports_.push_back(std::make_unique<NetworkPort>(*this, i));
      make_agent(i);
    }
    incarnation_.assign(n, 0);
    dead_.assign(n, false);
    paused_.assign(n, false);
  }

  rundir::RunRecord run() {
    const auto started = std::chrono::steady_clock::now();
    rundir::RunRecord record;
    record.scenario = scenario_;
    record.mode = "sim";
    record.agents = world_.size();
    record.anchors = world_.anchor_count();
    record.mean_degree = world_.mean_degree();
    rundir::compute_run_bounds(record, world_);
    record.processes = 1;
    record.extra["sim_clock"] = "agents";
    record.extra["network_delay_ms"] = scenario_.network.delay_ms;
    record.extra["network_jitter_ms"] = scenario_.network.jitter_ms;
    if (options_.recorder) options_.recorder->begin(scenario_, world_);

    // As over DDS: every agent announces its prior before the run starts, and its timer starts with
    // the run (START), whatever its clock reads; the first tick comes one local period later.
    for (AgentId i = 0; i < world_.size(); ++i) start_agent(i);
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

    rundir::update_run_optimum(record, true);
    std::vector<const runtime::AgentRuntime*> runtimes;
    runtimes.reserve(loops_.size());
    for (const auto& loop : loops_) runtimes.push_back(&loop->runtime());
    record_agents(record, world_, runtimes);
    record.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    return record;
  }

  /// Sends `publication` of `sender` to its neighbours now.
  void publish(AgentId sender, const runtime::AgentRuntime::Publication& publication) {
    auto shared = std::make_shared<const runtime::AgentRuntime::Publication>(publication);
    constexpr std::uint64_t kSampleKind = 0;
    for (AgentId receiver : world_.neighbours[static_cast<std::size_t>(sender)]) {
      push_arrival(now_s_, latency_s(sender, receiver, kSampleKind, shared->header.seq),
                   SampleArrival{receiver, now_s_, shared});
    }
  }

 private:
  runtime::AgentLoop& loop(AgentId id) { return *loops_[static_cast<std::size_t>(id)]; }
  [[nodiscard]] double world_time(std::int64_t step) const { return static_cast<double>(step) * period_s_; }

  void push(double time_s, Phase phase, decltype(Event::what) what) {
    queue_.push(Event{time_s, phase, next_order_++, std::move(what)});
  }

  /// Agent `id`'s process, as its manifest and the shared agent loop make it (a restart makes a new one).
  void make_agent(AgentId id) {
    const runtime::AgentManifest manifest = run::agent_manifest(shared_manifest_, world_, id);
    const auto k = static_cast<std::size_t>(id);
    const int incarnation = incarnation_.empty() ? 0 : incarnation_[k];
    runtime::LoopSettings settings =
        runtime::loop_settings(scenario_, manifest,
                               std::find(options_.hostile_agents.begin(), options_.hostile_agents.end(),
                                         id) != options_.hostile_agents.end());
    settings.reports = false;  // the simulator reads estimates where it scores them
    loops_[k] = std::make_unique<runtime::AgentLoop>(
        runtime::make_agent_runtime(scenario_, manifest, incarnation), settings, *ports_[k]);
  }

  /// The process announces its prior and starts its timer now (START, or a restart).
  void start_agent(AgentId id) {
    loop(id).announce(now_s_);
    loop(id).start(now_s_);
    push(loop(id).next_due_s(), Phase::kTick, Tick{id, incarnation_[static_cast<std::size_t>(id)]});
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

  void handle(const SampleArrival& arrival, rundir::RunRecord& /*record*/) {
    // A dead process receives nothing; a paused one keeps its reader cache (as in rounds mode).
    if (dead_[static_cast<std::size_t>(arrival.receiver)]) return;
    auto& receiver = loop(arrival.receiver);
    runtime::AgentRuntime::for_each_sample(
        *arrival.publication, [&](const runtime::Header& header, const auto& message) {
          if (options_.recorder) {
            options_.recorder->sample(runtime::ReceivedSample{
                arrival.receiver, receiver.runtime().steps_run(), virtual_ns(arrival.sent_s),
                virtual_ns(now_s_), true, header, runtime::SampleMessage(message)});
          }
          // Receiver-side loss, partition and ordering checks happen in the runtime, as over DDS.
          receiver.on_sample(runtime::InboundSample{header, message, true}, now_s_);
        });
  }

  void handle(const BatchArrival& arrival, rundir::RunRecord& /*record*/) {
    if (dead_[static_cast<std::size_t>(arrival.receiver)]) return;
    const auto stamp = static_cast<std::int64_t>(static_cast<double>(arrival.step) * period_s_ * 1e9);
    const runtime::Header header{kOrchestratorId, static_cast<std::uint32_t>(arrival.step), arrival.step,
                                 stamp, stamp};
    loop(arrival.receiver).on_batch(header, *arrival.batch, now_s_);  // keeps the newest, carries over
  }

  void handle(const Tick& tick, rundir::RunRecord& /*record*/) {
    const auto k = static_cast<std::size_t>(tick.agent);
    if (tick.incarnation != incarnation_[k] || dead_[k]) return;  // that process is gone
    loop(tick.agent).advance(now_s_);  // steps unless paused (SIGSTOP: the period passes), publishes
    push(loop(tick.agent).next_due_s(), Phase::kTick, tick);
  }
  void handle(const ScoreStep& score_step, rundir::RunRecord& record) {
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
      const auto& agent = loops_[k]->runtime();
      if (!dead_[k] && !paused_[k] && agent.steps_run() > 0) estimates[k] = agent.estimate();
    }
    rundir::StepMetrics metrics;
    metrics.step = score_step.step;
    metrics.time_s = world_time(score_step.step);
    metrics.errors = world::score(world_, estimates);
    rundir::note_scored_estimates(record, estimates);
    rundir::set_step_bounds(record, metrics);
    record.metrics.push_back(metrics);
    if (options_.record_estimates) {
      for (std::size_t k = 0; k < n; ++k) {
        if (estimates[k])
          record.estimates.push_back({score_step.step, static_cast<AgentId>(k), *estimates[k],
                                      world_.scored_truth(static_cast<AgentId>(k)),
                                      world_.scored_truth_z(static_cast<AgentId>(k))});
      }
    }
    if (options_.on_step && !score_step.settled) options_.on_step(score_step.step, metrics.errors);
  }

  void handle(const WorldStep& world_step, rundir::RunRecord& record) {
    const std::int64_t step = world_step.step;
    if (step > 0) world::advance_truth(world_, scenario_, step);
    apply_faults(step);
    constexpr std::uint64_t kBatchKind = 1;
    std::vector<estimators::MeasurementBatch> batches;
    batches.reserve(static_cast<std::size_t>(world_.size()));
    for (AgentId i = 0; i < world_.size(); ++i)
      batches.push_back(world::generate_batch(world_, scenario_, i, step));
    if (options_.recorder) options_.recorder->world_step(step, world_.truth, batches);
    rundir::observe_world_step(record, step, world_, batches);
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
        make_agent(fault.agent);
        dead_[k] = false;
        start_agent(fault.agent);
      }
    }
    for (const auto& fault : pauses_) {
      const auto k = static_cast<std::size_t>(fault.agent);
      if (fault.from_step == step) paused_[k] = true;
      if (fault.to_step == step) paused_[k] = false;
      loops_[k]->set_paused(paused_[k]);
    }
  }

  const config::Scenario& scenario_;
  const SimOptions& options_;
  world::World world_;
  double period_s_;
  std::uint64_t latency_seed_;
  std::vector<config::AgentFault> kills_;
  std::vector<config::AgentFault> pauses_;
  runtime::AgentManifest shared_manifest_;  ///< what every agent is told alike (run/manifests.hpp)
  std::vector<std::unique_ptr<NetworkPort>> ports_;
  std::vector<std::unique_ptr<runtime::AgentLoop>> loops_;
  std::vector<int> incarnation_;
  std::vector<bool> dead_;
  std::vector<bool> paused_;
  std::priority_queue<Event, std::vector<Event>, Later> queue_;
  std::uint64_t next_order_ = 0;
  double now_s_ = 0.0;
  bool finished_ = false;  ///< the final score is taken
};

void NetworkPort::publish(const runtime::AgentRuntime::Publication& publication) {
  simulation_.publish(agent_, publication);
}

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

rundir::RunRecord run_agent_clock_simulation(const config::Scenario& scenario, const SimOptions& options) {
  require_supported_sim_clock(scenario);
  return AgentClockSimulation(scenario, options).run();
}

}  // namespace swarmloc::sim
