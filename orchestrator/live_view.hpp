#pragma once
// The live view (`swarmloc run|sim … --view [PORT]`): a small HTTP server on 127.0.0.1 (cpp-httplib,
// Debian's libcpp-httplib-dev) that serves one embedded page (plain JavaScript + SVG, no build step)
// and the newest snapshot of the run as JSON:
//   GET /            the page; it polls /state.json about five times a second and redraws
//   GET /state.json  {step, steps, time_s, phase, done, agents: [{id, anchor, truth, estimate,
//                    covariance}], target, links: [{a, b, delivered_fraction, delivered, sent}], rmse_m,
//                    mean_error_m, max_error_m, crlb_rmse_m, bound_rmse_m, bound_kind, nees, scored,
//                    optimum_kind, optimum_step, optimum_rmse_m, efficiency, …}
//                    (target: [x, y] of the true target when the agents estimate it, dle; else null)
// The run loop calls publish() once per world step: it swaps a shared pointer under a mutex and
// returns, so the run never waits for the viewer; JSON is made on the server thread per request.
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/estimators/messages.hpp"
#include "swarmloc/rundir/run_record.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::orchestrator {

struct ViewAgent {
  AgentId id = 0;
  bool anchor = false;
  Vec2 truth = Vec2::Zero();
  double truth_z_m = 0.0;                        ///< the truth's z (3-D worlds; docs/design.md §3.1)
  std::optional<estimators::Estimate> estimate;  ///< nullopt: nothing scored from this agent yet
};

struct ViewLink {
  AgentId a = 0, b = 0;         ///< a < b; both directions pooled
  std::uint64_t delivered = 0;  ///< samples accepted by the receivers
  std::uint64_t sent = 0;       ///< samples the senders wrote while the link was up (0: no counters yet)
};

struct ViewSnapshot {
  std::string name;        ///< scenario name
  std::string algorithm;   ///< algorithm.name
  std::string mode;        ///< "dds" (live) or "sim" (paced playback of the finished in-process run)
  std::string phase;       ///< "waiting for agents", "running", "settling", "done", "playback"
  std::int64_t step = -1;  ///< world step just scored (0-based); -1 before the first
  int steps = 0;
  double rate_hz = 0.0;
  double area_m = 0.0;
  int dimensions = 2;     ///< 3: agents carry z, and the page adds a side view (x against z)
  double height_m = 0.0;  ///< the box's height in 3-D
  std::vector<ViewAgent> agents;
  /// The true target when the agents estimate it (dle): each estimate is scored against it, while the
  /// agents' truths stay their own positions.
  std::optional<Vec2> target;
  std::vector<ViewLink> links;
  double rmse_m = 0.0, mean_error_m = 0.0, max_error_m = 0.0, nees = 0.0;
  double crlb_rmse_m = 0.0;  ///< accumulated CRLB after step + 1 snapshots
  /// The run's bound at this step and its kind (rundir::RunRecord::bound, docs/algorithms.md §1.3.1).
  double bound_rmse_m = std::numeric_limits<double>::quiet_NaN();
  std::string bound_kind;
  /// The newest solved optimum of the run's data (docs/algorithms.md §1.3.2): its kind, step, RMSE, and the
  /// RMSE of that step over it (the efficiency). Solved at checkpoints, so it trails `step`.
  std::string optimum_kind;
  std::int64_t optimum_step = -1;
  double optimum_rmse_m = std::numeric_limits<double>::quiet_NaN();
  double efficiency = std::numeric_limits<double>::quiet_NaN();
  int scored = 0;            ///< non-anchor agents with an estimate
  bool has_metrics = false;  ///< false before the first scored step
  bool done = false;         ///< final: the figures equal summary.json's final.*
};

nlohmann::json snapshot_json(const ViewSnapshot& snapshot);

/// A snapshot of `world` before any estimate: true positions, anchors, the step-0 graph's links with
/// no counters, the scenario's name, algorithm, steps, rate and area.
ViewSnapshot view_snapshot(const config::Scenario& scenario, const world::World& world);
/// Adds the counters of the link sender -> receiver to its undirected link (if it is in the graph).
void add_link_counters(ViewSnapshot& snapshot, AgentId sender, AgentId receiver,
                       const runtime::LinkCounters& counters);
/// Copies a scored step's figures (step, RMSE, mean/max error, NEES, accumulated CRLB, scored agents).
void set_metrics(ViewSnapshot& snapshot, const rundir::StepMetrics& metrics);
/// The optimum's kind, and its newest solved step among record.metrics[0 … up_to] (default: all) with the
/// efficiency there.
void set_optimum(ViewSnapshot& snapshot, const rundir::RunRecord& record, std::size_t up_to = SIZE_MAX);

class LiveView;
/// `swarmloc sim --view`: replays a finished in-process run at run.rate_hz (estimates and scores per
/// step as recorded; links show the run's final counters). The last snapshot is marked done.
void play_back(LiveView& view, const config::Scenario& scenario, const rundir::RunRecord& record,
               const std::atomic<bool>& interrupted);

/// The embedded page (live_view_page.cpp).
const char* live_view_page();

class LiveView {
 public:
  /// Binds 127.0.0.1:`port` (0: any free port) and starts serving on a background thread.
  /// Throws std::runtime_error if the port cannot be bound.
  explicit LiveView(int port);
  ~LiveView();
  LiveView(const LiveView&) = delete;
  LiveView& operator=(const LiveView&) = delete;

  [[nodiscard]] int port() const { return port_; }
  [[nodiscard]] std::string url() const { return "http://127.0.0.1:" + std::to_string(port_) + "/"; }

  /// Replaces the current snapshot. Never blocks on a request being served (a pointer swap).
  void publish(ViewSnapshot snapshot);

  /// Keeps serving for `seconds` (infinite: until `interrupted`), returning early when `interrupted`.
  void hold(double seconds, const std::atomic<bool>& interrupted) const;

  /// Requests for /state.json served so far.
  [[nodiscard]] std::uint64_t state_requests() const { return state_requests_.load(); }

 private:
  struct Server;
  std::unique_ptr<Server> server_;
  int port_ = 0;
  std::thread thread_;
  mutable std::mutex mutex_;
  std::shared_ptr<const ViewSnapshot> current_;
  std::atomic<std::uint64_t> state_requests_{0};
};

}  // namespace swarmloc::orchestrator
