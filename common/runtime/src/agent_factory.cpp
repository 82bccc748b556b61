#include "swarmloc/runtime/agent_factory.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/config/scenario_models.hpp"
#include "swarmloc/estimators/params.hpp"

namespace swarmloc::runtime {
namespace {

/// The prior an agent starts from in the fusion centre and in the sensor-only placeholder.
class SensorOnly final : public estimators::Estimator {
 public:
  SensorOnly(const estimators::AgentSetup& setup, double initial_std_m) {
    estimate_.mean_m = setup.initial_guess_m;
    estimate_.covariance = Mat2::Identity() * initial_std_m * initial_std_m;
    estimate_.valid = false;
  }
  [[nodiscard]] std::string_view name() const override { return "sensor_only"; }
  [[nodiscard]] estimators::Outbox initial_outbox() const override { return {}; }
  estimators::StepOutput step(const estimators::StepInput& /*input*/) override { return {}; }
  [[nodiscard]] estimators::Estimate estimate() const override { return estimate_; }

 private:
  estimators::Estimate estimate_;
};

/// Every family's parameters from the scenario (the cooperative families: the algorithm knows the noise,
/// [D-6]); an algorithm's builder reads its own family's block only.
estimators::EstimatorParams estimator_params(const config::Scenario& s) {
  estimators::EstimatorParams params;
  params.bp.sigma2 = s.noise.range_std_m * s.noise.range_std_m;  // [D-6]: the algorithm knows the noise
  params.bp.exact_messages = s.algorithm.multipath.bp_messages == config::BpMessages::kExact;
  if (s.algorithm.multipath.path_variance == config::PathVariance::kWithDoa) {
    const double doa_max_rad = s.noise.doa_error_deg * std::numbers::pi / 180.0;
    params.bp.doa_variance_rad2 = doa_max_rad * doa_max_rad / 3.0;  // uniform on ±doa_max (world.cpp)
  }
  const config::AlgorithmSpec* spec =
      config::find_algorithm(s.algorithm.name);  // unknown: make_estimator throws
  const config::MeasurementKinds kinds = spec != nullptr ? spec->kinds : config::MeasurementKinds{};
  if (kinds.targets) {  // dle
    const config::TargetModel model = config::target_model(s);
    auto& dle = params.consensus.dle;
    dle.target = 0;
    dle.target_dim = model.dim;
    dle.F = model.F;
    dle.W = model.W;
    dle.initial_information = s.algorithm.kalman.initial_information;
    // Range–bearing readings are linearized at the area's centre until the first estimate exists.
    dle.initial_mean = VecX::Zero(model.dim);
    dle.initial_mean.head<2>() = Vec2::Constant(0.5 * s.world.area_m);
  }
  if (kinds.field) {  // joint_field
    // Anchors give Jacobi the world frame, which the field lives in: the reference is the origin.
    params.consensus.joint_field.sensor = config::field_sensor(s);
    params.consensus.joint_field.warmup_steps = s.algorithm.field.field_warmup_steps;
  }
  const config::GradientParams& keys = s.algorithm.gradient;
  auto& gradient = params.gradient;
  gradient.consensus_rounds = keys.consensus_rounds;
  gradient.fixed_step = keys.fixed_step;
  gradient.step_length = keys.step_length;
  gradient.abs_tol = keys.abs_tol;
  gradient.max_step = keys.max_step > 0.0 ? keys.max_step : std::numeric_limits<double>::infinity();
  gradient.max_move_fraction = keys.max_move_fraction;
  gradient.own_move_curvature = keys.local_bb_difference == config::LocalBbDifference::kOwnMove;
  // A run lasts run.steps rounds; the node itself never stops early for lack of updates.
  gradient.max_updates = std::numeric_limits<std::int64_t>::max() / 4;
  return params;
}

}  // namespace

std::unique_ptr<estimators::Estimator> make_agent_estimator(const config::Scenario& s,
                                                            const AgentManifest& manifest) {
  // Centralized algorithms run in the fusion centre; their agents are sensors only.
  if (config::runs_in_fusion_centre(s.algorithm.name))
    return make_sensor_only_estimator(manifest.setup, s.algorithm.kalman.initial_std_m);
  estimators::EstimatorParams params = estimator_params(s);
  const config::KalmanParams& kalman = s.algorithm.kalman;
  params.kalman.process_noise_std_m = kalman.process_noise_std_m;
  params.kalman.initial_information = kalman.initial_information;
  params.kalman.initial_std_m = kalman.initial_std_m;
  params.kalman.inflate_stale = kalman.inflate_stale;
  params.kalman.range_gate_chi2 = kalman.range_gate_chi2;
  params.kalman.update_iterations = kalman.update_iterations;
  params.kalman.initial_heading_std_rad = s.algorithm.pose.initial_heading_std_rad;
  params.kalman.range_bearing_gate_chi2 = s.algorithm.pose.range_bearing_gate_chi2;
  params.kalman.team_share_spans = s.algorithm.pose.team_share_spans;
  params.kalman.team_wait_steps = s.algorithm.pose.team_wait_steps;
  params.kalman.sighting_correlation_time_s = s.noise.sighting_correlation_time_s;
  params.kalman.range_correlated_fraction = s.noise.range_correlated_fraction;
  params.kalman.bearing_correlated_fraction = s.noise.bearing_correlated_fraction;
  params.kalman.sighting_cluster_radius_m = s.noise.sighting_cluster_radius_m;
  return config::make_estimator(s.algorithm.name, manifest.setup, params);
}

std::unique_ptr<estimators::Estimator> make_sensor_only_estimator(const estimators::AgentSetup& setup,
                                                                  double initial_std_m) {
  return std::make_unique<SensorOnly>(setup, initial_std_m);
}

AgentRuntime make_agent_runtime(const config::Scenario& scenario, const AgentManifest& manifest,
                                int incarnation) {
  return AgentRuntime(make_agent_estimator(scenario, manifest), manifest.setup, manifest.neighbours,
                      make_runtime_params(manifest, incarnation));
}

AgentRuntimeParams make_runtime_params(const AgentManifest& manifest, int incarnation) {
  AgentRuntimeParams params = manifest.runtime;
  params.first_seq = static_cast<std::uint32_t>(incarnation) << 24;
  return params;
}

double tick_phase_fraction(const config::Scenario& scenario, AgentId id) {
  if (scenario.run.tick_phase == config::TickPhase::kAligned) return 0.0;
  // Agents that all published in the same instant queued behind each other's bursts (inter-agent latency
  // p50 2.5 ms at N = 20, docs/scale.md); the golden ratio spreads any number of ids evenly.
  const double golden = std::numbers::phi - 1.0;
  return std::fmod(static_cast<double>(id) * golden, 1.0);
}

}  // namespace swarmloc::runtime
