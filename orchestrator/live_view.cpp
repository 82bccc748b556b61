#include "live_view.hpp"

#include <httplib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>

namespace swarmloc::orchestrator {
namespace {

nlohmann::json view_number_or_null(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json();
}

nlohmann::json point(const Vec2& p) {
  return nlohmann::json::array({view_number_or_null(p.x()), view_number_or_null(p.y())});
}

/// The third coordinate of a 3-D agent: the truth's z, the estimate's z and its standard deviation (null
/// where the estimate has none or its covariance is not valid).
void add_altitude(nlohmann::json& a, const ViewAgent& agent) {
  a["truth_z"] = view_number_or_null(agent.truth_z_m);
  const auto* altitude = agent.estimate && agent.estimate->altitude ? &*agent.estimate->altitude : nullptr;
  if (altitude == nullptr || a["estimate"].is_null()) {
    a["estimate_z"] = nullptr;
    a["z_std"] = nullptr;
    return;
  }
  a["estimate_z"] = view_number_or_null(altitude->z_m);
  a["z_std"] = agent.estimate->valid && altitude->variance_m2 >= 0.0
                   ? view_number_or_null(std::sqrt(altitude->variance_m2))
                   : nlohmann::json();
}

}  // namespace

nlohmann::json snapshot_json(const ViewSnapshot& s) {
  nlohmann::json agents = nlohmann::json::array();
  for (const auto& agent : s.agents) {
    nlohmann::json a = {{"id", agent.id}, {"anchor", agent.anchor}, {"truth", point(agent.truth)}};
    if (agent.estimate && agent.estimate->mean_m.allFinite()) {
      a["estimate"] = point(agent.estimate->mean_m);
      const auto& p = agent.estimate->covariance;
      a["covariance"] = agent.estimate->valid && p.allFinite()
                            ? nlohmann::json::array({p(0, 0), p(0, 1), p(1, 0), p(1, 1)})
                            : nlohmann::json();
    } else {
      a["estimate"] = nullptr;
      a["covariance"] = nullptr;
    }
    if (s.dimensions == 3) add_altitude(a, agent);
    agents.push_back(std::move(a));
  }
  nlohmann::json links = nlohmann::json::array();
  for (const auto& link : s.links) {
    const double fraction =
        link.sent == 0 ? std::numeric_limits<double>::quiet_NaN()
                       : std::min(1.0, static_cast<double>(link.delivered) / static_cast<double>(link.sent));
    links.push_back({{"a", link.a},
                     {"b", link.b},
                     {"delivered_fraction", view_number_or_null(fraction)},
                     {"delivered", link.delivered},
                     {"sent", link.sent}});
  }
  const auto metric = [&](double value) {
    return s.has_metrics ? view_number_or_null(value) : nlohmann::json();
  };
  return {{"name", s.name},
          {"algorithm", s.algorithm},
          {"mode", s.mode},
          {"phase", s.phase},
          {"step", s.step},
          {"steps", s.steps},
          {"rate_hz", s.rate_hz},
          {"time_s", s.step >= 0 && s.rate_hz > 0.0 ? static_cast<double>(s.step) / s.rate_hz : 0.0},
          {"area_m", s.area_m},
          {"dimensions", s.dimensions},
          {"height_m", s.height_m},
          {"agents", std::move(agents)},
          {"target", s.target ? point(*s.target) : nlohmann::json()},
          {"links", std::move(links)},
          {"rmse_m", metric(s.rmse_m)},
          {"mean_error_m", metric(s.mean_error_m)},
          {"max_error_m", metric(s.max_error_m)},
          {"nees", metric(s.nees)},
          {"crlb_rmse_m", metric(s.crlb_rmse_m)},
          {"bound_rmse_m", metric(s.bound_rmse_m)},
          {"bound_kind", s.bound_kind},
          {"optimum_kind", s.optimum_kind},
          {"optimum_step", s.optimum_step},
          {"optimum_rmse_m", view_number_or_null(s.optimum_rmse_m)},
          {"efficiency", view_number_or_null(s.efficiency)},
          {"scored", s.scored},
          {"done", s.done}};
}

ViewSnapshot view_snapshot(const config::Scenario& scenario, const world::World& world) {
  ViewSnapshot s;
  s.name = scenario.name;
  s.algorithm = scenario.algorithm.name;
  s.steps = static_cast<int>(scenario.run.steps);
  s.rate_hz = scenario.run.rate_hz;
  s.area_m = scenario.world.area_m;
  s.dimensions = world.dimensions;
  if (world.dimensions == 3) s.height_m = scenario.world.height_m;
  if (world.estimates_target()) s.target = world.scored_truth(0);
  s.agents.reserve(static_cast<std::size_t>(world.size()));
  for (AgentId i = 0; i < world.size(); ++i) {
    const auto index = static_cast<std::size_t>(i);
    const double z = world.dimensions == 3 ? world.altitude[index] : 0.0;
    s.agents.push_back({i, static_cast<bool>(world.is_anchor[index]), world.truth[index], z, std::nullopt});
    for (AgentId j : world.neighbours[index]) {
      if (i < j) s.links.push_back({i, j, 0, 0});
    }
  }
  std::sort(s.links.begin(), s.links.end(),
            [](const ViewLink& x, const ViewLink& y) { return std::pair(x.a, x.b) < std::pair(y.a, y.b); });
  return s;
}

void add_link_counters(ViewSnapshot& snapshot, AgentId sender, AgentId receiver,
                       const runtime::LinkCounters& counters) {
  const auto key = std::minmax(sender, receiver);
  auto it = std::lower_bound(snapshot.links.begin(), snapshot.links.end(), key,
                             [](const ViewLink& link, const auto& k) {
                               return std::pair(link.a, link.b) < std::pair(k.first, k.second);
                             });
  if (it == snapshot.links.end() || it->a != key.first || it->b != key.second) return;
  it->delivered += counters.delivered;
  it->sent += counters.sent();
}

void set_metrics(ViewSnapshot& snapshot, const rundir::StepMetrics& metrics) {
  snapshot.step = metrics.step;
  snapshot.rmse_m = metrics.errors.rmse_m;
  snapshot.mean_error_m = metrics.errors.mean_error_m;
  snapshot.max_error_m = metrics.errors.max_error_m;
  snapshot.nees = metrics.errors.nees;
  snapshot.crlb_rmse_m = metrics.crlb_rmse_m;
  snapshot.bound_rmse_m = metrics.bound_rmse_m;
  snapshot.scored = metrics.errors.scored;
  snapshot.has_metrics = true;
}

void set_optimum(ViewSnapshot& snapshot, const rundir::RunRecord& record, std::size_t up_to) {
  snapshot.optimum_kind = std::string(world::to_string(record.optimum.kind));
  const std::size_t end =
      std::min(up_to == SIZE_MAX ? record.metrics.size() : up_to + 1, record.metrics.size());
  for (std::size_t k = end; k-- > 0;) {
    const auto& m = record.metrics[k];
    if (!std::isfinite(m.optimum_rmse_m)) continue;
    snapshot.optimum_step = m.step;
    snapshot.optimum_rmse_m = m.optimum_rmse_m;
    snapshot.efficiency = m.errors.rmse_m / m.optimum_rmse_m;
    return;
  }
}

void play_back(LiveView& view, const config::Scenario& scenario, const rundir::RunRecord& record,
               const std::atomic<bool>& interrupted) {
  using SteadyClock = std::chrono::steady_clock;
  auto world = world::build_world(scenario);
  ViewSnapshot base = view_snapshot(scenario, world);
  base.mode = "sim";
  base.bound_kind = std::string(world::to_string(record.bound.kind));
  for (const auto& [key, counters] : record.links) add_link_counters(base, key.first, key.second, counters);
  std::map<std::int64_t, std::vector<const rundir::EstimateRow*>> rows;
  for (const auto& row : record.estimates) rows[row.step].push_back(&row);
  std::vector<std::optional<estimators::Estimate>> latest(base.agents.size());
  const auto period = std::chrono::duration_cast<SteadyClock::duration>(
      std::chrono::duration<double>(1.0 / scenario.run.rate_hz));
  auto next = SteadyClock::now();
  for (std::size_t k = 0; k < record.metrics.size() && !interrupted.load(); ++k) {
    const auto& metrics = record.metrics[k];
    if (metrics.step > 0) world::advance_truth(world, scenario, metrics.step);
    ViewSnapshot s = base;
    for (std::size_t i = 0; i < s.agents.size(); ++i) s.agents[i].truth = world.truth[i];
    if (s.target) s.target = world.scored_truth(0);
    if (const auto it = rows.find(metrics.step); it != rows.end()) {
      for (const auto* row : it->second) {
        const auto index = static_cast<std::size_t>(row->agent);
        if (index >= s.agents.size()) continue;
        latest[index] = row->estimate;
        // Exactly what was scored: the target (dle), else the agent's own position.
        (s.target ? *s.target : s.agents[index].truth) = row->truth;
      }
    }
    for (std::size_t i = 0; i < s.agents.size(); ++i) s.agents[i].estimate = latest[i];
    set_metrics(s, metrics);
    set_optimum(s, record, k);
    const bool done = k + 1 == record.metrics.size();
    s.done = done;
    s.phase = done ? "done" : "playback";
    view.publish(std::move(s));
    if (done) break;
    next += period;
    while (SteadyClock::now() < next && !interrupted.load())
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

struct LiveView::Server {
  httplib::Server http;
};

LiveView::LiveView(int port) : server_(std::make_unique<Server>()) {
  auto& http = server_->http;
  // httplib gives each connection a worker until it closes, and waits for an idle connection's request
  // for the keep-alive timeout (5 s by default): two idle sockets — a browser's speculative preconnects —
  // held both of two workers and stalled every poll for 5 s. Eight workers and a one-second wait bound
  // such a stall to a second even with more idle sockets than workers.
  http.new_task_queue = [] { return new httplib::ThreadPool(8); };
  http.set_keep_alive_timeout(1);
  http.set_read_timeout(1, 0);
  http.Get("/", [](const httplib::Request&, httplib::Response& response) {
    response.set_header("Cache-Control", "no-store");
    response.set_content(live_view_page(), "text/html; charset=utf-8");
  });
  http.Get("/state.json", [this](const httplib::Request&, httplib::Response& response) {
    std::shared_ptr<const ViewSnapshot> snapshot;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      snapshot = current_;
    }
    state_requests_.fetch_add(1);
    response.set_header("Cache-Control", "no-store");
    response.set_content(snapshot ? snapshot_json(*snapshot).dump() : std::string("{}"), "application/json");
  });
  // httplib's default sets SO_REUSEPORT, which would let a second server share a busy port silently.
  http.set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  if (port == 0) {
    port_ = http.bind_to_any_port("127.0.0.1");
    if (port_ <= 0) throw std::runtime_error("--view: could not bind any port on 127.0.0.1");
  } else {
    if (!http.bind_to_port("127.0.0.1", port)) {
      throw std::runtime_error("--view: could not bind 127.0.0.1:" + std::to_string(port) + " (in use?)");
    }
    port_ = port;
  }
  thread_ = std::thread([this] { server_->http.listen_after_bind(); });
  // stop() is a no-op until the accept loop runs, so the destructor must not race its start.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (!http.is_running() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

LiveView::~LiveView() {
  server_->http.stop();
  if (thread_.joinable()) thread_.join();
}

void LiveView::publish(ViewSnapshot snapshot) {
  auto next = std::make_shared<const ViewSnapshot>(std::move(snapshot));
  std::shared_ptr<const ViewSnapshot> previous;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    previous = std::exchange(current_, std::move(next));
  }
  // `previous` is freed here, outside the lock (or by the request still holding it).
}

void LiveView::hold(double seconds, const std::atomic<bool>& interrupted) const {
  using SteadyClock = std::chrono::steady_clock;
  const bool forever = !std::isfinite(seconds);
  const auto until =
      SteadyClock::now() + std::chrono::duration_cast<SteadyClock::duration>(
                               std::chrono::duration<double>(forever ? 0.0 : std::max(0.0, seconds)));
  while (!interrupted.load() && (forever || SteadyClock::now() < until)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

}  // namespace swarmloc::orchestrator
