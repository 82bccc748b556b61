#include "monitor.hpp"

#include <spdlog/spdlog.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <memory>
#include <optional>

#include "live_view.hpp"
#include "swarmloc/config/deployment.hpp"
#include "swarmloc/dds/live_io.hpp"
#include "swarmloc/rundir/run_record.hpp"
#include "swarmloc/runtime/run_health.hpp"

namespace swarmloc::orchestrator {
namespace {

std::atomic<bool> g_monitor_stop{false};

void on_monitor_signal(int /*signal*/) { g_monitor_stop.store(true); }

double monitor_mono_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// What the monitor has seen: the newest pose and truth of each team member, sampled once per period.
class MonitorBook {
 public:
  MonitorBook(const config::Deployment& deployment, bool with_truth)
      : deployment_(deployment),
        with_truth_(with_truth),
        poses_(deployment.team.size()),
        truth_(deployment.team.size()),
        pose_counts_(deployment.team.size(), 0),
        truth_counts_(deployment.team.size(), 0) {
    for (const auto& member : deployment.team) {
      is_anchor_.push_back(member.anchor.has_value());
      if (member.anchor) truth_[static_cast<std::size_t>(member.id)] = *member.anchor;
    }
  }

  void take(dds::LiveMonitorIo& io) {
    for (const auto& pose : io.take_poses()) {
      estimators::Estimate estimate;
      estimate.mean_m = pose.position_m;
      estimate.covariance = pose.covariance;
      estimate.valid = true;
      poses_[pose.robot] = estimate;
      ++pose_counts_[pose.robot];
      ++poses_taken_;
    }
    for (const auto& truth : io.take_truth()) {
      if (is_anchor_[truth.robot]) continue;  // an anchor's truth is its deployment position
      truth_[truth.robot] = truth.position_m;
      ++truth_counts_[truth.robot];
    }
  }

  /// One row per member with a pose, and (with truth for every robot) the step's scores.
  void sample(rundir::RunRecord& record, double time_s) {
    const std::int64_t step = samples_++;
    bool truth_complete = with_truth_;
    std::vector<Vec2> truth(poses_.size(), Vec2::Zero());
    for (std::size_t i = 0; i < poses_.size(); ++i) {
      if (truth_[i])
        truth[i] = *truth_[i];
      else
        truth_complete = false;
      if (!poses_[i]) continue;
      const Vec2 row_truth = truth_[i].value_or(Vec2::Constant(std::numeric_limits<double>::quiet_NaN()));
      record.estimates.push_back({step, static_cast<AgentId>(i), *poses_[i], row_truth});
    }
    if (!truth_complete) {
      ++unscored_steps_;
      return;
    }
    rundir::StepMetrics metrics;
    metrics.step = step;
    metrics.time_s = time_s;
    metrics.errors = world::score(truth, is_anchor_, poses_);
    record.metrics.push_back(metrics);
  }

  /// The live view of the newest sample: every member's pose, scored against the truth where known (a
  /// member without truth is drawn at its estimate).
  [[nodiscard]] ViewSnapshot snapshot(const config::Scenario& scenario,
                                      const rundir::RunRecord& record) const {
    ViewSnapshot view;
    view.name = scenario.name;
    view.algorithm = scenario.algorithm.name;
    view.mode = "live";
    view.phase = "running";
    view.step = samples_ - 1;
    view.rate_hz = scenario.run.rate_hz;
    view.area_m = 1.0;
    for (std::size_t i = 0; i < poses_.size(); ++i) {
      const Vec2 fallback = poses_[i] ? poses_[i]->mean_m : Vec2::Zero();
      view.agents.push_back(
          {static_cast<AgentId>(i), is_anchor_[i], truth_[i].value_or(fallback), 0.0, poses_[i]});
    }
    if (const auto* metrics = record.final_metrics(); metrics != nullptr && metrics->step == view.step)
      set_metrics(view, *metrics);
    return view;
  }

  [[nodiscard]] std::uint64_t poses_taken() const { return poses_taken_; }
  [[nodiscard]] std::int64_t unscored_steps() const { return unscored_steps_; }
  [[nodiscard]] nlohmann::json counts() const {
    nlohmann::json robots = nlohmann::json::object();
    for (const auto& member : deployment_.team) {
      const auto i = static_cast<std::size_t>(member.id);
      robots[member.name] = {{"id", member.id}, {"poses", pose_counts_[i]}, {"truth", truth_counts_[i]}};
    }
    return robots;
  }
  [[nodiscard]] std::vector<std::string> silent_members() const {
    std::vector<std::string> names;
    for (const auto& member : deployment_.team)
      if (pose_counts_[static_cast<std::size_t>(member.id)] == 0) names.push_back(member.name);
    return names;
  }
  [[nodiscard]] const std::vector<bool>& is_anchor() const { return is_anchor_; }

 private:
  const config::Deployment& deployment_;
  bool with_truth_;
  std::vector<bool> is_anchor_;
  std::vector<std::optional<estimators::Estimate>> poses_;
  std::vector<std::optional<Vec2>> truth_;
  std::vector<std::uint64_t> pose_counts_;
  std::vector<std::uint64_t> truth_counts_;
  std::uint64_t poses_taken_ = 0;
  std::int64_t unscored_steps_ = 0;
  std::int64_t samples_ = 0;
};

/// Health of a monitored run: the steps the monitor sampled and non-finite estimates, plus every team
/// member that published no pose.
runtime::RunHealth monitor_health(const rundir::RunRecord& record, const MonitorBook& book, double rate_hz,
                                  std::int64_t samples, double seconds) {
  runtime::RunHealthInput input;
  input.rate_hz = rate_hz;
  input.world_steps = samples;
  input.world_steps_s = seconds;
  input.non_finite_steps = rundir::non_finite_estimates(record).steps;
  runtime::RunHealth health = runtime::assess_health(input);
  for (const auto& name : book.silent_members()) {
    health.healthy = false;
    health.reasons.push_back(name + " published no pose");
  }
  return health;
}

struct MonitorSetup {
  config::Deployment deployment;
  config::Scenario scenario;
  std::string truth_leaf;
};

std::optional<MonitorSetup> monitor_setup(const MonitorOptions& options) {
  try {
    MonitorSetup setup;
    setup.deployment = config::load_deployment(options.deployment_path);
    setup.scenario = config::deployment_scenario(setup.deployment);
    setup.truth_leaf = options.truth_topic.empty() ? setup.deployment.truth_topic : options.truth_topic;
    if (setup.truth_leaf == "none") setup.truth_leaf.clear();
    rundir::prepare_run_directory(options.out_dir, options.force);
    return setup;
  } catch (const config::DeploymentError& error) {
    spdlog::error("{}", error.what());
  } catch (const config::ScenarioError& error) {
    spdlog::error("{}", error.what());
  }
  return std::nullopt;
}

rundir::RunRecord monitor_record(const MonitorSetup& setup) {
  rundir::RunRecord record;
  record.scenario = setup.scenario;
  record.mode = "live";
  record.agents = static_cast<int>(setup.deployment.team.size());
  for (const auto& member : setup.deployment.team) {
    record.anchors += member.anchor ? 1 : 0;
    rundir::AgentSummary summary;
    summary.agent = member.id;
    summary.anchor = member.anchor.has_value();
    record.agent_summaries.push_back(summary);
  }
  record.bound.reason = "a live run has no world to bound";
  return record;
}

/// Samples the team once per period until stopped, the duration passes, or the poses stop.
std::int64_t monitor_loop(const MonitorOptions& options, const MonitorSetup& setup, dds::LiveMonitorIo& io,
                          MonitorBook& book, rundir::RunRecord& record, LiveView* view) {
  const double period_s = 1.0 / setup.deployment.rate_hz;
  const double started_s = monitor_mono_s();
  double last_pose_s = started_s;
  std::uint64_t poses_before = 0;
  std::int64_t samples = 0;
  while (!g_monitor_stop.load()) {
    io.wait(period_s);
    book.take(io);
    const double now_s = monitor_mono_s();
    if (book.poses_taken() > poses_before) last_pose_s = now_s;
    const bool seen = book.poses_taken() > 0;
    poses_before = book.poses_taken();
    if (seen) {
      book.sample(record, now_s - started_s);
      ++samples;
      if (view != nullptr) view->publish(book.snapshot(setup.scenario, record));
    }
    if (options.duration_s > 0.0 && now_s - started_s > options.duration_s) break;
    if (seen && now_s - last_pose_s > options.idle_s) break;
    if (!options.quiet && samples > 0 &&
        samples % static_cast<std::int64_t>(10 * setup.deployment.rate_hz) == 0) {
      const auto* final_metrics = record.final_metrics();
      std::fprintf(stderr, "\rmonitor: %lld samples, %llu poses%s%.4f m   ", static_cast<long long>(samples),
                   static_cast<unsigned long long>(book.poses_taken()), final_metrics ? ", RMSE " : "",
                   final_metrics ? final_metrics->errors.rmse_m : 0.0);
    }
  }
  record.wall_s = monitor_mono_s() - started_s;
  record.interrupted = g_monitor_stop.load();
  return samples;
}

}  // namespace

int run_monitor(const MonitorOptions& options) {
  std::signal(SIGINT, on_monitor_signal);
  std::signal(SIGTERM, on_monitor_signal);
  const auto setup = monitor_setup(options);
  if (!setup) return 2;
  try {
    std::vector<std::string> pose_topics, truth_topics;
    for (const auto& member : setup->deployment.team) {
      pose_topics.push_back(config::Deployment::dds_topic(member.name, setup->deployment.pose_topic));
      truth_topics.push_back(setup->truth_leaf.empty() || member.anchor
                                 ? std::string()
                                 : config::Deployment::dds_topic(member.name, setup->truth_leaf));
    }
    dds::LiveMonitorIo io(setup->scenario, static_cast<int>(pose_topics.size()), pose_topics, truth_topics);
    MonitorBook book(setup->deployment, !setup->truth_leaf.empty());
    rundir::RunRecord record = monitor_record(*setup);
    std::unique_ptr<LiveView> view;
    if (options.view_port >= 0) {
      view = std::make_unique<LiveView>(options.view_port);
      std::printf("monitor: live view on %s\n", view->url().c_str());
      std::fflush(stdout);
    }
    const std::int64_t samples = monitor_loop(options, *setup, io, book, record, view.get());
    const runtime::RunHealth health =
        monitor_health(record, book, setup->deployment.rate_hz, samples, record.wall_s);
    record.extra["health"] = runtime::to_json(health);
    const bool scored = !record.metrics.empty();
    record.extra["live"] = {{"deployment", options.deployment_path},
                            {"truth_topic", setup->truth_leaf.empty() ? "none" : setup->truth_leaf},
                            {"scored", scored},
                            {"samples", samples},
                            {"unscored_samples", book.unscored_steps()},
                            {"robots", book.counts()}};
    if (!scored) {
      record.extra["live"]["note"] = "no ground truth for every robot: nothing is scored";
      spdlog::warn("no ground truth for every robot: the monitor records the estimates and scores nothing");
    }
    rundir::write_run_directory(options.out_dir, record);
    if (!options.quiet) std::fprintf(stderr, "\n");
    if (scored) std::printf("%s", rundir::result_table(record).c_str());
    std::printf("monitor: %lld samples, %llu poses -> %s\n", static_cast<long long>(samples),
                static_cast<unsigned long long>(book.poses_taken()), options.out_dir.c_str());
    return 0;
  } catch (const std::exception& error) {
    spdlog::error("monitor: {}", error.what());
    return 1;
  }
}

}  // namespace swarmloc::orchestrator
