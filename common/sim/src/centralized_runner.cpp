#include "swarmloc/sim/centralized_runner.hpp"

#include <algorithm>
#include <chrono>

#include "swarmloc/estimators/centralized/relabeling.hpp"

namespace swarmloc::sim {
namespace {

namespace centralized = estimators::centralized;

std::vector<centralized::Edge> graph_edges(const world::World& world) {
  std::vector<centralized::Edge> edges;
  for (int i = 0; i < world.size(); ++i) {
    for (AgentId j : world.neighbours[static_cast<std::size_t>(i)]) {
      if (i < j) edges.emplace_back(i, j);
    }
  }
  return edges;
}

}  // namespace

rundir::RunRecord run_centralized_simulation(const config::Scenario& scenario, const SimOptions& options) {
  const auto started = std::chrono::steady_clock::now();
  world::World world = world::build_world(scenario, options.trial);
  world::attach_recorded(world, options.recorded);
  if (options.recorder) options.recorder->begin(scenario, world);
  const int n = world.size();
  auto filter = run::make_fusion_filter(scenario, world);

  rundir::RunRecord record;
  record.scenario = scenario;
  record.mode = "sim";
  record.agents = n;
  record.anchors = world.anchor_count();
  record.mean_degree = world.mean_degree();
  rundir::compute_run_bounds(record, world);
  record.processes = 1;

  std::vector<std::optional<estimators::Estimate>> estimates(static_cast<std::size_t>(n));
  std::vector<estimators::MeasurementBatch> batches(static_cast<std::size_t>(n));
  std::vector<const estimators::MeasurementBatch*> pointers(static_cast<std::size_t>(n));
  nlohmann::json total_mse = nlohmann::json::array();
  int truncated_steps = 0;
  for (std::int64_t step = 0; step < scenario.run.steps; ++step) {
    if (step > 0) world::advance_truth(world, scenario, step);
    for (AgentId i = 0; i < n; ++i) {
      batches[static_cast<std::size_t>(i)] = world::generate_batch(world, scenario, i, step);
      pointers[static_cast<std::size_t>(i)] = &batches[static_cast<std::size_t>(i)];
    }
    if (options.recorder) options.recorder->world_step(step, world.truth, batches);
    rundir::observe_world_step(record, step, world, batches);
    filter->step(run::centralized_measurements(scenario, pointers));
    if (filter->last_truncated_entries() > 0) ++truncated_steps;
    for (AgentId i = 0; i < n; ++i) estimates[static_cast<std::size_t>(i)] = run::fusion_estimate(*filter, i);

    rundir::StepMetrics metrics;
    metrics.step = step;
    metrics.time_s = world::reported_time_s(scenario, step);
    metrics.errors = world::score(world, estimates);
    rundir::note_scored_estimates(record, estimates);
    rundir::set_step_bounds(record, metrics);
    record.metrics.push_back(metrics);
    total_mse.push_back(run::total_squared_error(world.truth, estimates, world.altitude));
    if (options.record_estimates) {
      for (AgentId i = 0; i < n; ++i) {
        record.estimates.push_back({step, i, *estimates[static_cast<std::size_t>(i)], world.scored_truth(i),
                                    world.scored_truth_z(i)});
      }
    }
    if (options.on_step) options.on_step(step, metrics.errors);
  }

  rundir::update_run_optimum(record, true);
  for (AgentId i = 0; i < n; ++i) {
    rundir::AgentSummary summary;
    summary.agent = i;
    summary.anchor = world.is_anchor[static_cast<std::size_t>(i)];
    summary.steps_run = static_cast<std::uint32_t>(filter->steps_done());
    record.agent_summaries.push_back(summary);
  }
  record.extra["final_total_mse_m2"] = total_mse.empty() ? 0.0 : total_mse.back().get<double>();
  record.extra["total_mse_m2"] = std::move(total_mse);
  record.extra["fusion_center"] = {
      {"filter", std::string(filter->name())},
      {"bandwidth", run::centralized_bandwidth(world.dimensions)},
      {"graph_bandwidth", centralized::graph_bandwidth(graph_edges(world), filter->labels())},
      {"truncated_steps", truncated_steps}};
  record.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return record;
}

}  // namespace swarmloc::sim
