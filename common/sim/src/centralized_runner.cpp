#include "swarmloc/sim/centralized_runner.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <stdexcept>
#include <string_view>

#include "swarmloc/estimators/builders.hpp"
#include "swarmloc/estimators/centralized/relabeling.hpp"

namespace swarmloc::sim {
namespace {

namespace centralized = estimators::centralized;

constexpr double kMinVariance = 1e-6;  // m²: exactly known anchors / noiseless ranges stay finite

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

std::unique_ptr<centralized::CentralizedFilter> make_fusion_filter(const config::Scenario& scenario,
                                                                   const world::World& world) {
  const std::string& algorithm = scenario.algorithm.name;
  const config::AlgorithmSpec* spec = config::find_algorithm(algorithm);
  const estimators::EstimatorBuilder* builder = spec != nullptr ? &spec->build : nullptr;
  if (!config::runs_in_fusion_centre(algorithm) || builder == nullptr || !builder->fusion) {
    throw std::invalid_argument("make_fusion_filter: algorithm '" + algorithm + "' is not centralized");
  }
  const int n = world.size();
  VecX initial_mean(2 * n);
  for (int i = 0; i < n; ++i)
    initial_mean.segment<2>(2 * i) = world.initial_guess[static_cast<std::size_t>(i)];
  const double initial_var =
      scenario.algorithm.kalman.initial_std_m * scenario.algorithm.kalman.initial_std_m;
  const std::vector<Mat2> initial_cov(static_cast<std::size_t>(n), Mat2::Identity() * initial_var);

  centralized::CentralizedFilterParams params;
  params.process_var =
      scenario.algorithm.kalman.process_noise_std_m * scenario.algorithm.kalman.process_noise_std_m;
  params.bandwidth = kCentralizedBandwidth;
  // Khan et al. Alg. 3 with: the relabelling variants relabel once, from the best positions at
  // start-up.
  params.labels = builder->relabel ? centralized::lexicographic_labels(world.initial_guess)
                                   : centralized::identity_labels(n);
  // A static generated world ranges every pair within the radius at every step (world generate_batch);
  // a moving one only its step-0 pairs, so there a pair never ranged may well be within it.
  const bool disk_graph = scenario.world.source == config::WorldSource::kGenerated &&
                          scenario.world.motion == config::Motion::kStatic;
  if (disk_graph) params.disk_radius_m = scenario.world.comm_radius_m;
  return centralized::make_centralized_filter(*builder->fusion, initial_mean, initial_cov, params);
}

centralized::CentralizedMeasurements centralized_measurements(
    const config::Scenario& scenario, const std::vector<const estimators::MeasurementBatch*>& batches) {
  centralized::CentralizedMeasurements out;
  out.beacon_var = std::max(kMinVariance, scenario.noise.anchor_fix_std_m * scenario.noise.anchor_fix_std_m);
  out.range_var = std::max(kMinVariance, scenario.noise.range_std_m * scenario.noise.range_std_m);
  const int n = static_cast<int>(batches.size());
  for (int i = 0; i < n; ++i) {
    const auto* batch = batches[static_cast<std::size_t>(i)];
    if (batch == nullptr) continue;
    if (batch->fix) out.beacon_fixes.emplace_back(i, batch->fix->position_m);
    for (const auto& range : batch->ranges) {
      const int j = range.peer;
      if (j < 0 || j >= n || j == i) continue;
      // One range per undirected edge: the lower endpoint's, or the higher one's if the lower is missing.
      const bool lower = i < j;
      if (lower || batches[static_cast<std::size_t>(j)] == nullptr) {
        out.ranges.push_back({std::min(i, j), std::max(i, j), range.range_m});
      }
    }
  }
  return out;
}

estimators::Estimate fusion_estimate(const centralized::CentralizedFilter& filter, AgentId agent) {
  estimators::Estimate estimate;
  estimate.mean_m = filter.agent_mean(agent);
  estimate.covariance = filter.covariance_block(agent);
  estimate.valid = estimate.mean_m.allFinite() && estimate.covariance.allFinite();
  estimate.inconsistent = filter.inconsistent(agent);
  return estimate;
}

double total_squared_error(const std::vector<Vec2>& truth,
                           const std::vector<std::optional<estimators::Estimate>>& estimates) {
  double total = 0.0;
  for (std::size_t i = 0; i < truth.size() && i < estimates.size(); ++i) {
    if (estimates[i]) total += (estimates[i]->mean_m - truth[i]).squaredNorm();
  }
  return total;
}

rundir::RunRecord run_centralized_simulation(const config::Scenario& scenario, const SimOptions& options) {
  const auto started = std::chrono::steady_clock::now();
  world::World world = world::build_world(scenario, options.trial);
  world::attach_recorded(world, options.recorded);
  if (options.recorder) options.recorder->begin(scenario, world);
  const int n = world.size();
  auto filter = make_fusion_filter(scenario, world);

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
    rundir::observe_world_step(record, step, world.truth, batches);
    filter->step(centralized_measurements(scenario, pointers));
    if (filter->last_truncated_entries() > 0) ++truncated_steps;
    for (AgentId i = 0; i < n; ++i) estimates[static_cast<std::size_t>(i)] = fusion_estimate(*filter, i);

    rundir::StepMetrics metrics;
    metrics.step = step;
    metrics.time_s = world::reported_time_s(scenario, step);
    metrics.errors = world::score(world, estimates);
    rundir::set_step_bounds(record, metrics);
    record.metrics.push_back(metrics);
    total_mse.push_back(total_squared_error(world.truth, estimates));
    if (options.record_estimates) {
      for (AgentId i = 0; i < n; ++i) {
        record.estimates.push_back({step, i, *estimates[static_cast<std::size_t>(i)], world.scored_truth(i)});
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
      {"bandwidth", kCentralizedBandwidth},
      {"graph_bandwidth", centralized::graph_bandwidth(graph_edges(world), filter->labels())},
      {"truncated_steps", truncated_steps}};
  record.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return record;
}

}  // namespace swarmloc::sim
