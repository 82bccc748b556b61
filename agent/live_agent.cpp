#include "live_agent.hpp"

#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <fstream>
#include <nlohmann/json.hpp>

#include "dds_port.hpp"
#include "live_input.hpp"
#include "swarmloc/dds/live_io.hpp"
#include "swarmloc/runtime/agent_factory.hpp"
#include "swarmloc/runtime/process_cpu.hpp"

namespace swarmloc::agent {
namespace {

std::atomic<bool> g_live_stop{false};

// Only sets a flag: never call DDS from a signal handler (docs/style.md).
void on_live_signal(int /*signal*/) { g_live_stop.store(true); }

double live_mono_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// The loop's outputs: inter-agent samples and the swarmloc estimate as for any agent, and each estimate
/// of a step as the robot's pose and tf, stamped with the robot's clock.
class LivePort final : public DdsPort {
 public:
  LivePort(dds::AgentTransport& transport, dds::LiveRobotIo& io, const LiveStreamGate& ranges,
           const LiveStreamGate& odom, spdlog::logger& logger)
      : DdsPort(transport, logger), io_(io), ranges_(ranges), odom_(odom) {}

  void report(const runtime::EstimateReport& report) override {
    DdsPort::report(report);
    if (report.steps_run == 0 || !report.estimate.valid) return;
    io_.publish_pose(report, robot_now_ns());
    ++poses_;
  }
  [[nodiscard]] std::uint64_t poses() const { return poses_; }

 private:
  /// The robot's clock as its sensors stamp it; before any sensor data (an anchor without a driver) the
  /// host's system clock, which is ROS's default clock.
  std::int64_t robot_now_ns() const {
    const double now_s = live_mono_s();
    if (ranges_.has_data()) return ranges_.robot_now_ns(now_s);
    if (odom_.has_data()) return odom_.robot_now_ns(now_s);
    return std::chrono::duration_cast<std::chrono::nanoseconds>(
               std::chrono::system_clock::now().time_since_epoch())
        .count();
  }

  dds::LiveRobotIo& io_;
  const LiveStreamGate& ranges_;
  const LiveStreamGate& odom_;
  std::uint64_t poses_ = 0;
};

dds::LiveNames live_names(const config::Deployment& d, const std::string& robot) {
  dds::LiveNames names;
  names.ranges_topic = config::Deployment::dds_topic(robot, d.ranges_topic);
  names.odom_topic = config::Deployment::dds_topic(robot, d.odom_topic);
  names.pose_topic = config::Deployment::dds_topic(robot, d.pose_topic);
  names.map_frame = d.map_frame;
  names.base_frame = robot + "/" + d.base_frame;
  return names;
}

/// One live agent process.
class LiveAgent {
 public:
  LiveAgent(const config::Deployment& deployment, const config::Scenario& scenario,
            const runtime::AgentManifest& manifest, const LiveOptions& options, spdlog::logger& logger)
      : deployment_(deployment),
        options_(options),
        logger_(logger),
        manifest_(manifest),
        transport_(scenario, topology()),
        io_(scenario, topology(), live_names(deployment, options.robot)),
        ranges_(deployment.limits),
        odom_(deployment.limits),
        port_(transport_, io_, ranges_, odom_, logger),
        loop_(runtime::make_agent_runtime(scenario, manifest), runtime::loop_settings(scenario, manifest),
              port_) {}

  int run() {
    start_s_ = live_mono_s();
    loop_.announce(start_s_);
    loop_.start(start_s_);
    logger_.info("live: {} (agent {}{}), {} team members, reading {}", options_.robot, manifest_.id,
                 manifest_.setup.anchor ? ", anchor" : "", manifest_.agent_count,
                 config::Deployment::dds_topic(options_.robot, deployment_.ranges_topic));
    while (!g_live_stop.load()) {
      const double wait_s = std::clamp(loop_.next_due_s() - live_mono_s(), 0.0, 0.05);
      feed_samples(transport_.wait_and_take(wait_s));
      const double now_s = live_mono_s();
      reannounce(now_s);
      feed_sensors(now_s);
      loop_.set_cpu_s(runtime::process_cpu_s());
      loop_.advance(now_s);
      if (options_.duration_s > 0.0 && now_s - start_s_ > options_.duration_s) break;
    }
    finish();
    return 0;
  }

 private:
  dds::Topology topology() const {
    return dds::Topology{manifest_.id, manifest_.agent_count, manifest_.neighbours};
  }

  void feed_samples(const dds::AgentInbound& inbound) { agent::feed_samples(loop_, inbound, live_mono_s()); }

  /// A neighbour whose reader matched late missed our prior: announce it again.
  void reannounce(double now_s) {
    const int readers = transport_.matched_neighbour_readers();
    if (readers <= announced_to_) return;
    announced_to_ = readers;
    loop_.announce(now_s);
  }

  void feed_sensors(double now_s) {
    for (const auto& odom : io_.take_odom()) odom_.admit(odom.stamp_ns, -1, now_s);
    for (auto& sweep : io_.take_ranges()) {
      const bool was_silent = ranges_.silent();
      if (ranges_.admit(sweep.stamp_ns, sweep.sweep, now_s) != LiveStreamGate::Verdict::kAccept) continue;
      if (was_silent) logger_.warn("ranges again after a silence; {}", to_string(ranges_.counters()));
      loop_.on_batch(runtime::Header{manifest_.id, 0, batches_, sweep.stamp_ns, 0}, batch_of(sweep, now_s),
                     now_s);
    }
    const bool was_silent = ranges_.silent();
    ranges_.poll(now_s);
    odom_.poll(now_s);
    if (!was_silent && ranges_.silent())
      logger_.warn("no ranges for {:.1f} s: the range driver stopped?", deployment_.limits.silence_s);
  }

  /// The sweep's own ranges as the estimator's batch (an anchor adds its known position).
  estimators::MeasurementBatch batch_of(const dds::RangeSweep& sweep, double now_s) {
    estimators::MeasurementBatch batch;
    batch.world_step = batches_++;
    batch.world_time_s = now_s - start_s_;
    for (std::size_t k = 0; k < sweep.ranges.size(); ++k) {
      const auto& range = sweep.ranges[k];
      const bool known_peer =
          range.peer >= 0 && range.peer < manifest_.agent_count && range.peer != manifest_.id;
      if (sweep.measured_by[k] != manifest_.id || !known_peer || !(range.range_m >= 0.0)) {
        ++foreign_ranges_;
        continue;
      }
      batch.ranges.push_back(range);
      batch.neighbours.push_back(range.peer);
    }
    std::sort(batch.neighbours.begin(), batch.neighbours.end());
    batch.neighbours.erase(std::unique(batch.neighbours.begin(), batch.neighbours.end()),
                           batch.neighbours.end());
    if (manifest_.setup.anchor)
      batch.fix = estimators::AbsoluteFix{manifest_.setup.initial_guess_m, Mat2::Zero(), std::nullopt};
    return batch;
  }

  void finish() {
    port_.report(loop_.report(live_mono_s(), runtime::process_cpu_s()));
    logger_.info("stopping after {} steps, {} poses; ranges: {}; odom: {}; ranges dropped (not ours) {}",
                 loop_.runtime().steps_run(), port_.poses(), to_string(ranges_.counters()),
                 to_string(odom_.counters()), foreign_ranges_);
    if (!options_.stats_path.empty()) write_stats();
  }

  void write_stats() const {
    auto counters = [](const LiveStreamCounters& c) {
      return nlohmann::json{{"accepted", c.accepted},   {"duplicates", c.duplicates},
                            {"reordered", c.reordered}, {"clock_jumps", c.clock_jumps},
                            {"silences", c.silences},   {"restarts", c.restarts}};
    };
    const auto estimate = loop_.runtime().estimate();
    const nlohmann::json stats{{"robot", options_.robot},
                               {"id", manifest_.id},
                               {"steps", loop_.runtime().steps_run()},
                               {"poses", port_.poses()},
                               {"ranges", counters(ranges_.counters())},
                               {"odom", counters(odom_.counters())},
                               {"ranges_not_ours", foreign_ranges_},
                               {"estimate", {estimate.mean_m.x(), estimate.mean_m.y()}}};
    std::ofstream out(options_.stats_path);
    out << stats.dump(2) << "\n";
    if (!out) logger_.error("cannot write {}", options_.stats_path);
  }

  const config::Deployment& deployment_;
  const LiveOptions& options_;
  spdlog::logger& logger_;
  runtime::AgentManifest manifest_;
  dds::AgentTransport transport_;
  dds::LiveRobotIo io_;
  LiveStreamGate ranges_;
  LiveStreamGate odom_;
  LivePort port_;
  runtime::AgentLoop loop_;
  double start_s_ = 0.0;
  std::int64_t batches_ = 0;
  std::uint64_t foreign_ranges_ = 0;
  int announced_to_ = 0;
};

std::shared_ptr<spdlog::logger> live_logger(const LiveOptions& options) {
  const std::string name = "live-" + options.robot;
  auto logger = options.log_path.empty() ? spdlog::stderr_color_mt(name)
                                         : spdlog::basic_logger_mt(name, options.log_path, true);
  logger->set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ [" + name + "] %v");
  logger->flush_on(spdlog::level::info);
  return logger;
}

}  // namespace

runtime::AgentManifest live_manifest(const config::Deployment& deployment, const config::Scenario& scenario,
                                     const config::TeamMember& member) {
  runtime::AgentManifest manifest;
  manifest.id = member.id;
  manifest.agent_count = static_cast<int>(deployment.team.size());
  Vec2 centroid = Vec2::Zero();
  int anchors = 0;
  for (const auto& other : deployment.team) {
    if (other.id != member.id) manifest.neighbours.push_back(other.id);
    if (other.anchor) {
      centroid += *other.anchor;
      ++anchors;
    }
  }
  if (anchors > 0) centroid /= anchors;
  const Vec2 start = member.anchor ? *member.anchor : member.start.value_or(centroid);
  manifest.setup = estimators::AgentSetup{member.id, member.anchor.has_value(), start};
  manifest.setup.initial_guess_std_m = scenario.world.initial_guess_std_m;
  manifest.setup.comm_radius_m = scenario.world.comm_radius_m;
  manifest.runtime.world_period_s = 1.0 / scenario.run.rate_hz;
  manifest.results_hash = config::results_hash(scenario);
  manifest.run_id = scenario.dds.run_id;
  return manifest;
}

int run_live_agent(const LiveOptions& options) {
  std::signal(SIGINT, on_live_signal);
  std::signal(SIGTERM, on_live_signal);
  std::signal(SIGPIPE, SIG_IGN);
  auto logger = live_logger(options);
  config::Deployment deployment;
  config::Scenario scenario;
  const config::TeamMember* member = nullptr;
  try {
    deployment = config::load_deployment(options.deployment_path);
    scenario = config::deployment_scenario(deployment);
    member = deployment.find(options.robot);
    // As `swarmloc run` does: fixed DDS ports inside the ephemeral range make an agent fail to start at
    // random.
    dds::require_ports_clear_of(scenario, dds::ephemeral_port_range());
  } catch (const config::DeploymentError& error) {
    logger->error("{}", error.what());
    return 2;
  } catch (const config::ScenarioError& error) {
    logger->error("{}: {}", options.deployment_path, error.what());
    return 2;
  }
  if (member == nullptr) {
    logger->error("--robot {}: not in the team of {}", options.robot, options.deployment_path);
    return 2;
  }
  try {
    LiveAgent agent(deployment, scenario, live_manifest(deployment, scenario, *member), options, *logger);
    return agent.run();
  } catch (const std::exception& error) {
    logger->error("runtime failure: {}", error.what());
    return 1;
  }
}

}  // namespace swarmloc::agent
