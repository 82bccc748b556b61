// The live view (issue 8 point 2): `swarmloc run … --view PORT` serves a page on 127.0.0.1 that
// draws the agents. The page is loaded in headless Chromium (Debian's `chromium`) during the run and
// after it; the DOM must show every agent and, once the run is done, the RMSE and CRLB of summary.json.
// Skips with a message when chromium is not installed (scripts/install-deps.sh installs it).
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <optional>
#include <regex>
#include <thread>

#include "process_helpers.hpp"

namespace live_view_test {
namespace {

using swarmloc::testing::count_processes_matching;
using swarmloc::testing::free_port;
using swarmloc::testing::fresh_directory;
using swarmloc::testing::read_json;
using swarmloc::testing::run_command;
using Clock = std::chrono::steady_clock;

const std::string kBinary = SWARMLOC_BINARY;
const std::string kScenario = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/ieif.yaml";
constexpr int kAgents = 6;
constexpr int kSteps = 150;

std::optional<std::string> find_chromium() {
  for (const char* candidate : {"/usr/bin/chromium", "/usr/bin/chromium-browser", "/usr/bin/google-chrome"}) {
    if (access(candidate, X_OK) == 0) return std::string(candidate);
  }
  return std::nullopt;
}

/// A background `swarmloc` process; SIGKILLed if the test ends while it runs.
class Background {
 public:
  Background(const std::string& command, const std::filesystem::path& log) {
    pid_ = fork();
    if (pid_ == 0) {
      const std::string shell = "exec " + command + " >" + log.string() + " 2>&1";
      execl("/bin/sh", "sh", "-c", shell.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
  }
  ~Background() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  Background(const Background&) = delete;
  Background& operator=(const Background&) = delete;

  /// Sends `signal` (0: none) and waits; the exit code (128 + signal if killed by one).
  int stop(int signal) {
    if (signal != 0) kill(pid_, signal);
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }

 private:
  pid_t pid_ = -1;
};

std::optional<nlohmann::json> get_state(int port) {
  httplib::Client client("127.0.0.1", port);
  client.set_connection_timeout(1, 0);
  client.set_read_timeout(2, 0);
  const auto response = client.Get("/state.json");
  if (!response || response->status != 200) return std::nullopt;
  return nlohmann::json::parse(response->body, nullptr, false);
}

/// Polls /state.json until `ready` holds (or the deadline passes).
std::optional<nlohmann::json> wait_for_state(int port, double timeout_s,
                                             const std::function<bool(const nlohmann::json&)>& ready) {
  const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
  while (Clock::now() < deadline) {
    if (auto state = get_state(port); state && !state->is_discarded() && ready(*state)) return state;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return std::nullopt;
}

/// The DOM after Chromium has run the page for `budget_ms` of virtual time.
std::string dump_dom(const std::string& chromium, const std::string& url,
                     const std::filesystem::path& profile) {
  return run_command(chromium + " --headless --no-sandbox --disable-gpu --no-first-run --user-data-dir=" +
                     profile.string() + " --virtual-time-budget=3000 --dump-dom " + url + " 2>/dev/null")
      .output;
}

std::string body_attribute(const std::string& dom, const std::string& name) {
  std::smatch match;
  const std::regex pattern("<body[^>]*\\s" + name + "=\"([^\"]*)\"");
  return std::regex_search(dom, match, pattern) ? match[1].str() : std::string("(absent)");
}

std::string element_text(const std::string& dom, const std::string& id) {
  std::smatch match;
  const std::regex pattern("id=\"" + id + "\"[^>]*>([^<]*)<");
  return std::regex_search(dom, match, pattern) ? match[1].str() : std::string("(absent)");
}

/// The drawn map: the <svg id="map"> element only (the page's script holds the same markup as text).
std::string map_of(const std::string& dom) {
  const auto begin = dom.find("<svg id=\"map\"");
  if (begin == std::string::npos) return {};
  const auto end = dom.find("</svg>", begin);
  return dom.substr(begin, end == std::string::npos ? std::string::npos : end - begin);
}

int count_of(const std::string& text, const std::string& needle) {
  int count = 0;
  for (auto at = text.find(needle); at != std::string::npos; at = text.find(needle, at + 1)) ++count;
  return count;
}

TEST(LiveView, HeadlessChromiumDrawsEveryAgentAndShowsTheSummaryFigures) {
  const auto chromium = find_chromium();
  if (!chromium)
    GTEST_SKIP() << "chromium is not installed (apt-get install chromium; scripts/install-deps.sh does)";
  const auto started = Clock::now();
  const auto dir = fresh_directory("live-view");
  const int port = free_port();
  ASSERT_GT(port, 0);
  const std::string url = "http://127.0.0.1:" + std::to_string(port) + "/";
  Background run(
      kBinary + " run " + kScenario + " --out " + dir.string() +
          " -q --set world.agents=" + std::to_string(kAgents) +
          " --set world.anchors=3 --set world.area_m=20 --set run.steps=" + std::to_string(kSteps) +
          " --set run.rate_hz=10 --set dds.domain_id=43 --view " + std::to_string(port) + " --view-hold 60",
      dir.parent_path() / (dir.filename().string() + ".log"));

  // While the run is live: every agent is drawn and the step advances.
  const auto live = wait_for_state(port, 20.0, [](const auto& s) { return s.value("step", -1) >= 10; });
  ASSERT_TRUE(live) << "no live state with step >= 10 on " << url;
  const auto dom_live = dump_dom(*chromium, url, dir / "chromium-profile");
  EXPECT_EQ(body_attribute(dom_live, "data-agents"), std::to_string(kAgents)) << dom_live;
  EXPECT_GE(std::stoi(body_attribute(dom_live, "data-step")), 10);
  EXPECT_EQ(count_of(map_of(dom_live), "class=\"truth"), kAgents);
  EXPECT_EQ(count_of(map_of(dom_live), "class=\"estimate\""), kAgents - 3)
      << "one estimate per non-anchor agent";

  // After the run: the final snapshot, summary.json written.
  const auto final_state = wait_for_state(port, 30.0, [](const auto& s) { return s.value("done", false); });
  ASSERT_TRUE(final_state) << "the run did not finish";
  ASSERT_TRUE(std::filesystem::exists(dir / "summary.json"));
  const auto summary = read_json(dir / "summary.json");
  const double rmse = summary["final"]["rmse_m"];
  const double crlb = summary["final"]["crlb_rmse_m"];
  EXPECT_DOUBLE_EQ((*final_state)["rmse_m"].get<double>(), rmse) << "state.json and summary.json disagree";

  const auto dom = dump_dom(*chromium, url, dir / "chromium-profile");
  EXPECT_EQ(body_attribute(dom, "data-done"), "1") << dom;
  EXPECT_EQ(body_attribute(dom, "data-agents"), std::to_string(summary["agents"].get<int>()));
  EXPECT_EQ(body_attribute(dom, "data-step"), std::to_string(kSteps - 1));
  const std::string shown_rmse = element_text(dom, "rmse");
  const std::string shown_crlb = element_text(dom, "crlb");
  EXPECT_EQ(shown_rmse, body_attribute(dom, "data-rmse"));
  // The page prints 4 decimals, as the result table does.
  EXPECT_NEAR(std::stod(shown_rmse), rmse, 0.5e-4 + 1e-12)
      << "page shows " << shown_rmse << ", summary " << rmse;
  EXPECT_NEAR(std::stod(shown_crlb), crlb, 0.5e-4 + 1e-12)
      << "page shows " << shown_crlb << ", summary " << crlb;
  // The run's bound and its kind (docs/algorithms.md §1.3.1), as summary.json's `bound`.
  EXPECT_EQ(element_text(dom, "boundkind"), summary["bound"]["kind"].get<std::string>());
  EXPECT_NEAR(std::stod(element_text(dom, "bound")), summary["bound"]["rmse_m"].get<double>(),
              0.5e-4 + 1e-12);
  // The optimum of the run's own data and the efficiency (docs/algorithms.md §1.3.2), 3 decimals.
  EXPECT_EQ(element_text(dom, "optimumkind"), summary["optimum"]["kind"].get<std::string>());
  EXPECT_NEAR(std::stod(element_text(dom, "efficiency")), summary["efficiency"].get<double>(),
              0.5e-3 + 1e-12);
  EXPECT_EQ(count_of(map_of(dom), "<ellipse class=\"ellipse\""), kAgents - 3)
      << "one 95 % ellipse per estimate";
  EXPECT_EQ(static_cast<std::size_t>(count_of(map_of(dom), "class=\"link\"")),
            (*final_state)["links"].size());

  // --view-hold keeps serving; Ctrl-C (SIGINT) ends the hold and the run still counts as a success.
  EXPECT_TRUE(swarmloc::testing::completed_run(run.stop(SIGINT)));
  EXPECT_EQ(count_processes_matching(dir.string()), 0) << "agent processes outlived the run";
  const double elapsed = std::chrono::duration<double>(Clock::now() - started).count();
  EXPECT_LT(elapsed, 30.0);
  std::printf("live-view test: %.1f s; final RMSE %.6f m shown as %s\n", elapsed, rmse, shown_rmse.c_str());
}

TEST(LiveView, SimPlaybackEndsOnTheSummaryFiguresAndTheHoldExpires) {
  const auto dir = fresh_directory("live-view-sim");
  const int port = free_port();
  ASSERT_GT(port, 0);
  Background sim(kBinary + " sim " + kScenario + " --out " + dir.string() +
                     " -q --set run.steps=40 --set run.rate_hz=40 --view=" + std::to_string(port) +
                     " --view-hold 1",
                 dir.parent_path() / (dir.filename().string() + ".log"));
  const auto final_state = wait_for_state(port, 20.0, [](const auto& s) { return s.value("done", false); });
  ASSERT_TRUE(final_state);
  const auto summary = read_json(dir / "summary.json");
  EXPECT_EQ((*final_state)["mode"], "sim");
  EXPECT_TRUE((*final_state)["target"].is_null()) << "agents estimate themselves";
  EXPECT_EQ((*final_state)["step"], 39);
  EXPECT_EQ((*final_state)["agents"].size(), summary["agents"].get<std::size_t>());
  EXPECT_DOUBLE_EQ((*final_state)["rmse_m"].get<double>(), summary["final"]["rmse_m"].get<double>());
  EXPECT_DOUBLE_EQ((*final_state)["crlb_rmse_m"].get<double>(),
                   summary["final"]["crlb_rmse_m"].get<double>());
  EXPECT_DOUBLE_EQ((*final_state)["bound_rmse_m"].get<double>(), summary["bound"]["rmse_m"].get<double>());
  EXPECT_EQ((*final_state)["bound_kind"], summary["bound"]["kind"]);
  EXPECT_EQ((*final_state)["optimum_kind"], summary["optimum"]["kind"]);
  EXPECT_EQ((*final_state)["optimum_step"], 39);
  EXPECT_DOUBLE_EQ((*final_state)["efficiency"].get<double>(), summary["efficiency"].get<double>());
  // The 1 s hold expires by itself: the server goes away.
  const auto deadline = Clock::now() + std::chrono::seconds(5);
  while (get_state(port) && Clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_FALSE(get_state(port)) << "still serving after --view-hold 1";
  EXPECT_EQ(sim.stop(0), 0) << "sim --view exits 0 when the hold expires";
}

// dle: every sensor estimates the target. The view shows the sensors where they are and the target beside
// them, and each estimate's error is its distance to the target (before, every sensor was drawn on the
// target in a playback, and live the error lines ran from each sensor to its estimate of the target).
TEST(LiveView, ADleRunShowsTheTargetAndEveryEstimatesErrorIsItsDistanceToIt) {
  const auto dir = fresh_directory("live-view-dle");
  const int port = free_port();
  ASSERT_GT(port, 0);
  Background sim(kBinary + " sim " + std::string(SWARMLOC_SOURCE_DIR) +
                     "/scenarios/dle_tracking.yaml --out " + dir.string() +
                     " -q --set run.steps=40 --set run.rate_hz=40 --view=" + std::to_string(port) +
                     " --view-hold 1",
                 dir.parent_path() / (dir.filename().string() + ".log"));
  const auto final_state = wait_for_state(port, 20.0, [](const auto& s) { return s.value("done", false); });
  ASSERT_TRUE(final_state);
  const auto& state = *final_state;
  ASSERT_TRUE(state["target"].is_array());
  const double tx = state["target"][0], ty = state["target"][1];
  double squared = 0.0;
  int estimates = 0, away_from_target = 0;
  for (const auto& agent : state["agents"]) {
    if (std::hypot(agent["truth"][0].get<double>() - tx, agent["truth"][1].get<double>() - ty) > 1.0)
      ++away_from_target;
    if (agent["estimate"].is_null()) continue;
    ++estimates;
    squared += std::pow(agent["estimate"][0].get<double>() - tx, 2) +
               std::pow(agent["estimate"][1].get<double>() - ty, 2);
  }
  const auto summary = read_json(dir / "summary.json");
  EXPECT_EQ(estimates, 30);
  EXPECT_GT(away_from_target, 25) << "the sensors are drawn where they are, not on the target";
  const double rmse = summary["final"]["rmse_m"];
  EXPECT_NEAR(std::sqrt(squared / estimates), rmse, 1e-9 * rmse);
  EXPECT_EQ(sim.stop(0), 0);
}

/// The drawn side view of a 3-D run: the <svg id="side"> element only.
std::string side_of(const std::string& dom) {
  const auto begin = dom.find("<svg id=\"side\"");
  if (begin == std::string::npos) return {};
  const auto end = dom.find("</svg>", begin);
  return dom.substr(begin, end == std::string::npos ? std::string::npos : end - begin);
}

// A 3-D world (docs/design.md §3.1): state.json carries each agent's z, its truth's z and z's standard
// deviation, so the error in space it implies is summary.json's; the page adds a side view with every agent.
TEST(LiveView, A3dRunShowsEveryAgentsAltitudeInASideView) {
  const auto dir = fresh_directory("live-view-3d");
  const int port = free_port();
  ASSERT_GT(port, 0);
  const std::string url = "http://127.0.0.1:" + std::to_string(port) + "/";
  Background sim(kBinary + " sim " + std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/default3d.yaml --out " +
                     dir.string() + " -q --set run.steps=20 --set run.rate_hz=40 --view=" +
                     std::to_string(port) + " --view-hold 30",
                 dir.parent_path() / (dir.filename().string() + ".log"));
  const auto final_state = wait_for_state(port, 20.0, [](const auto& s) { return s.value("done", false); });
  ASSERT_TRUE(final_state);
  const auto& state = *final_state;
  EXPECT_EQ(state["dimensions"], 3);
  EXPECT_EQ(state["height_m"], 10.0);
  double squared = 0.0;
  int estimates = 0;
  for (const auto& agent : state["agents"]) {
    ASSERT_TRUE(agent["truth_z"].is_number());
    if (agent["anchor"].get<bool>() || agent["estimate"].is_null()) continue;
    ASSERT_TRUE(agent["estimate_z"].is_number());
    EXPECT_GT(agent["z_std"].get<double>(), 0.0);
    squared += std::pow(agent["estimate"][0].get<double>() - agent["truth"][0].get<double>(), 2) +
               std::pow(agent["estimate"][1].get<double>() - agent["truth"][1].get<double>(), 2) +
               std::pow(agent["estimate_z"].get<double>() - agent["truth_z"].get<double>(), 2);
    ++estimates;
  }
  const auto summary = read_json(dir / "summary.json");
  const double rmse = summary["final"]["rmse_m"];
  EXPECT_EQ(estimates, 22);
  EXPECT_NEAR(std::sqrt(squared / estimates), rmse, 1e-9 * rmse);
  if (const auto chromium = find_chromium()) {
    const auto dom = dump_dom(*chromium, url, dir / "chromium-profile");
    EXPECT_EQ(count_of(side_of(dom), "class=\"side-truth"), 30) << dom;
    EXPECT_EQ(count_of(side_of(dom), "class=\"side-estimate\""), 22);
    EXPECT_EQ(count_of(side_of(dom), "class=\"side-bar\""), 22) << "a z interval per estimate";
    EXPECT_EQ(element_text(dom, "neesdof"), "3");
  }
  EXPECT_EQ(sim.stop(SIGINT), 0) << "Ctrl-C ends the hold";
}

TEST(LiveView, BusyPortIsReportedBeforeAnythingStarts) {
  // Hold a port, then ask for it: the run fails at once naming the port (no agents started).
  httplib::Server blocker;
  const int port = blocker.bind_to_any_port("127.0.0.1");
  ASSERT_GT(port, 0);
  const auto dir = fresh_directory("live-view-busy");
  const auto result = run_command(kBinary + " sim " + kScenario + " --out " + dir.string() + " -q --view " +
                                  std::to_string(port));
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find(std::to_string(port)), std::string::npos) << result.output;
}

}  // namespace
}  // namespace live_view_test
