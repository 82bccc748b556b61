#include "swarmloc/sim/simulator.hpp"

#include <chrono>

#include "swarmloc/sim/agent_runtime.hpp"

namespace swarmloc::sim {

std::unique_ptr<estimators::Estimator> make_agent_estimator(const config::Scenario& s, const World& world,
                                                            AgentId id) {
  estimators::KalmanFamilyParams params;
  params.process_noise_std_m = s.algorithm.process_noise_std_m;
  params.initial_information = s.algorithm.initial_information;
  params.initial_std_m = s.algorithm.initial_std_m;
  params.inflate_stale = s.algorithm.inflate_stale;
  return estimators::make_estimator(s.algorithm.name, world.setup_of(id), params);
}

AgentRuntimeParams make_runtime_params(const config::Scenario& s) {
  AgentRuntimeParams params;
  params.seed = s.seed;
  params.loss.loss_probability = s.network.loss;
  params.absurd_position_bound_m = absurd_position_bound_m(s);
  return params;
}

RunRecord run_simulation(const config::Scenario& scenario, const SimOptions& options) {
  const auto started = std::chrono::steady_clock::now();
  World world = build_world(scenario);
  const int n = world.size();
  std::vector<AgentRuntime> agents;
  agents.reserve(static_cast<std::size_t>(n));
  for (AgentId i = 0; i < n; ++i) {
    agents.emplace_back(make_agent_estimator(scenario, world, i), world.setup_of(i),
                        world.neighbours[static_cast<std::size_t>(i)], make_runtime_params(scenario));
  }

  RunRecord record;
  record.scenario = scenario;
  record.mode = "sim";
  record.agents = n;
  record.anchors = world.anchor_count();
  record.mean_degree = world.mean_degree();
  record.crlb = range_crlb(world, scenario.noise.range_std_m);
  record.processes = 1;

  const double period_s = 1.0 / scenario.run.rate_hz;
  auto stamp_ns = [&](std::int64_t step) { return static_cast<std::int64_t>(static_cast<double>(step) * period_s * 1e9); };
  std::vector<AgentRuntime::Publication> published(static_cast<std::size_t>(n));
  for (AgentId i = 0; i < n; ++i) published[static_cast<std::size_t>(i)] = agents[static_cast<std::size_t>(i)].initial_publication(0);

  std::vector<std::optional<estimators::Estimate>> estimates(static_cast<std::size_t>(n));
  for (std::int64_t step = 0; step < scenario.run.steps; ++step) {
    if (step > 0) advance_truth(world, scenario, step);
    // Deliver round k−1's samples over the lossy bus, then the world-step-k batches.
    for (AgentId sender = 0; sender < n; ++sender) {
      const auto& publication = published[static_cast<std::size_t>(sender)];
      if (!publication.outbox.state) continue;
      for (AgentId receiver : world.neighbours[static_cast<std::size_t>(sender)]) {
        agents[static_cast<std::size_t>(receiver)].on_state(publication.header, *publication.outbox.state);
      }
    }
    for (AgentId i = 0; i < n; ++i) {
      Header header{kOrchestratorId, static_cast<std::uint32_t>(step), step, stamp_ns(step), stamp_ns(step)};
      agents[static_cast<std::size_t>(i)].on_batch(header, generate_batch(world, scenario, i, step));
    }
    for (AgentId i = 0; i < n; ++i) {
      published[static_cast<std::size_t>(i)] = agents[static_cast<std::size_t>(i)].step(stamp_ns(step));
      estimates[static_cast<std::size_t>(i)] = agents[static_cast<std::size_t>(i)].estimate();
    }
    StepMetrics metrics;
    metrics.step = step;
    metrics.time_s = static_cast<double>(step) * period_s;
    metrics.errors = score(world.truth, world.is_anchor, estimates);
    metrics.crlb_rmse_m = record.crlb.accumulated_rmse_m(static_cast<double>(step + 1));
    record.metrics.push_back(metrics);
    if (options.record_estimates) {
      for (AgentId i = 0; i < n; ++i) {
        record.estimates.push_back({step, i, *estimates[static_cast<std::size_t>(i)], world.truth[static_cast<std::size_t>(i)]});
      }
    }
    if (options.on_step) options.on_step(step, metrics.errors);
  }

  for (AgentId i = 0; i < n; ++i) {
    const auto& agent = agents[static_cast<std::size_t>(i)];
    for (const auto& [sender, counters] : agent.links()) record.links[{sender, i}] = counters;
    AgentSummary summary;
    summary.agent = i;
    summary.anchor = world.is_anchor[static_cast<std::size_t>(i)];
    summary.steps_run = static_cast<std::uint32_t>(agent.steps_run());
    summary.rejected_by_reason = agent.rejected_by_reason();
    record.agent_summaries.push_back(summary);
  }
  record.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return record;
}

}  // namespace swarmloc::sim
