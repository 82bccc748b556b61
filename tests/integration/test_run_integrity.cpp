// Every run tells the truth (issue 24; docs/robustness.md): an agent killed or stopped behind the
// orchestrator's back is reported and unscored and the run exits 3 (degraded); a second run on the same
// domain is refused before it starts and the first ends with its own result; an agent started with
// another scenario is refused at hello and exits 2; SIGHUP and a closed stdout leave a complete run
// directory. Real processes throughout.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "process_helpers.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/runtime/manifest.hpp"

namespace run_integrity_test {
namespace {

using swarmloc::testing::count_processes_matching;
using swarmloc::testing::fresh_directory;
using swarmloc::testing::read_json;
using swarmloc::testing::read_text;
using Clock = std::chrono::steady_clock;

const std::string kBinary = SWARMLOC_BINARY;
const std::string kScenario = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/ieif.yaml";

/// A child process with stdout and stderr in `log` (stdout: a pipe whose reader is gone, if asked).
class Child {
 public:
  Child(std::vector<std::string> args, const std::filesystem::path& log, bool closed_stdout = false)
      : log_(log) {
    int pipe_fds[2] = {-1, -1};
    if (closed_stdout && ::pipe(pipe_fds) != 0) return;
    pid_ = ::fork();
    if (pid_ == 0) {
      const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      ::dup2(closed_stdout ? pipe_fds[1] : fd, STDOUT_FILENO);
      ::dup2(fd, STDERR_FILENO);
      if (closed_stdout) {
        ::close(pipe_fds[0]);  // no reader left anywhere once the parent closes its end too
        ::close(pipe_fds[1]);
      }
      std::vector<char*> argv;
      for (auto& arg : args) argv.push_back(arg.data());
      argv.push_back(nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
    if (closed_stdout) {
      ::close(pipe_fds[0]);  // `| head -1` after head has gone: every write gets EPIPE / SIGPIPE
      ::close(pipe_fds[1]);
    }
  }
  ~Child() {
    if (pid_ > 0 && !status_) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;

  [[nodiscard]] pid_t pid() const { return pid_; }
  [[nodiscard]] std::string output() const { return read_text(log_); }

  /// Waits until the log contains `text` (true) or `timeout_s` passes.
  bool wait_for_output(const std::string& text, double timeout_s) const {
    const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
    while (Clock::now() < deadline) {
      if (output().find(text) != std::string::npos) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return false;
  }

  /// Exit code (or 128 + signal); nullopt if still running after `timeout_s`.
  std::optional<int> wait(double timeout_s) {
    const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
    while (!status_ && Clock::now() < deadline) {
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        status_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      } else {
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      }
    }
    return status_;
  }

 private:
  std::filesystem::path log_;
  pid_t pid_ = -1;
  std::optional<int> status_;
};

std::vector<std::string> run_args(const std::filesystem::path& dir, int domain, int agents, int steps) {
  return {kBinary,
          "run",
          kScenario,
          "--out",
          dir.string(),
          "--set",
          "world.agents=" + std::to_string(agents),
          "--set",
          "world.anchors=3",
          "--set",
          "run.steps=" + std::to_string(steps),
          "--set",
          "dds.domain_id=" + std::to_string(domain)};
}

/// The pid of agent `id`'s process of the run in `dir` (its command line names the run directory).
std::optional<pid_t> agent_pid(const std::filesystem::path& dir, int id) {
  const std::string needle = (dir / "scenario.yaml").string() + " --id " + std::to_string(id) + " ";
  for (const auto& entry : std::filesystem::directory_iterator("/proc")) {
    const auto name = entry.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream in(entry.path() / "cmdline", std::ios::binary);
    std::string cmdline((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    for (auto& c : cmdline) c = c == '\0' ? ' ' : c;
    if (cmdline.find(needle) != std::string::npos) return static_cast<pid_t>(std::stol(name));
  }
  return std::nullopt;
}

/// agents.csv as rows of cells (header row first).
std::vector<std::vector<std::string>> read_csv(const std::filesystem::path& path) {
  std::vector<std::vector<std::string>> rows;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> cells;
    std::stringstream stream(line);
    for (std::string cell; std::getline(stream, cell, ',');) cells.push_back(cell);
    rows.push_back(cells);
  }
  return rows;
}

std::string agents_csv_cell(const std::filesystem::path& dir, int agent, const std::string& column) {
  const auto rows = read_csv(dir / "agents.csv");
  if (rows.empty()) return "<no agents.csv>";
  std::size_t col = 0;
  while (col < rows[0].size() && rows[0][col] != column) ++col;
  for (std::size_t r = 1; r < rows.size(); ++r) {
    if (!rows[r].empty() && rows[r][0] == std::to_string(agent) && col < rows[r].size()) return rows[r][col];
  }
  return "<missing>";
}

/// Steps at which `agent` was scored (estimates.csv rows).
std::vector<long> scored_steps(const std::filesystem::path& dir, int agent) {
  std::vector<long> steps;
  const auto rows = read_csv(dir / "estimates.csv");
  for (std::size_t r = 1; r < rows.size(); ++r) {
    if (rows[r].size() > 1 && rows[r][1] == std::to_string(agent)) steps.push_back(std::stol(rows[r][0]));
  }
  return steps;
}

TEST(RunIntegrity, AnAgentKilledBehindTheOrchestratorsBackIsReportedUnscoredAndDegradesTheRun) {
  const auto dir = fresh_directory("integrity-kill");
  Child run(run_args(dir, 61, 8, 100), dir.parent_path() / (dir.filename().string() + ".log"));
  ASSERT_TRUE(run.wait_for_output(" step ", 60.0)) << run.output();
  const auto victim = agent_pid(dir, 2);
  ASSERT_TRUE(victim.has_value()) << "agent 2's process not found";
  ASSERT_EQ(::kill(*victim, SIGKILL), 0);

  const auto code = run.wait(90.0);
  ASSERT_TRUE(code.has_value()) << run.output();
  EXPECT_EQ(*code, 3) << "an unscheduled death makes the run degraded\n" << run.output();
  EXPECT_NE(run.output().find("agent 2 died"), std::string::npos) << run.output();
  EXPECT_NE(run.output().find("reporting 7/8"), std::string::npos) << run.output();
  EXPECT_NE(run.output().find("DEGRADED"), std::string::npos) << run.output();

  const auto summary = read_json(dir / "summary.json");
  EXPECT_EQ(summary["health"]["verdict"], "degraded");
  EXPECT_EQ(summary["liveness"]["unscheduled_deaths"], 1);
  ASSERT_FALSE(summary["liveness"]["events"].empty());
  EXPECT_EQ(summary["liveness"]["events"][0]["agent"], 2);
  EXPECT_EQ(summary["liveness"]["events"][0]["event"], "died");
  EXPECT_NE(summary["liveness"]["events"][0]["reason"].get<std::string>().find("signal 9"),
            std::string::npos);
  const bool victim_is_anchor = agents_csv_cell(dir, 2, "anchor") == "1";
  EXPECT_EQ(summary["final"]["scored_agents"], 5 - (victim_is_anchor ? 0 : 1));  // 8 agents, 3 anchors
  EXPECT_EQ(summary["final"]["lost_agents"], 1);
  EXPECT_EQ(agents_csv_cell(dir, 2, "fate"), "died");
  const long died_at = summary["liveness"]["events"][0]["step"].get<long>();
  for (const long step : scored_steps(dir, 2)) EXPECT_LT(step, died_at) << "scored after its death";
  EXPECT_EQ(count_processes_matching(dir.string()), 0) << "agent processes outlived the run";
}

TEST(RunIntegrity, AStoppedAgentIsAStallUnscoredWhileSilentAndTheRunIsDegraded) {
  const auto dir = fresh_directory("integrity-stop");
  Child run(run_args(dir, 62, 8, 150), dir.parent_path() / (dir.filename().string() + ".log"));
  ASSERT_TRUE(run.wait_for_output(" step ", 60.0)) << run.output();
  const auto victim = agent_pid(dir, 4);
  ASSERT_TRUE(victim.has_value());
  ASSERT_EQ(::kill(*victim, SIGSTOP), 0);
  std::this_thread::sleep_for(std::chrono::seconds(5));
  ASSERT_EQ(::kill(*victim, SIGCONT), 0);

  const auto code = run.wait(90.0);
  ASSERT_TRUE(code.has_value()) << run.output();
  EXPECT_EQ(*code, 3) << run.output();
  const auto summary = read_json(dir / "summary.json");
  EXPECT_EQ(summary["health"]["verdict"], "degraded");
  EXPECT_GE(summary["liveness"]["stalls"], 1);
  long stalled_at = -1, resumed_at = -1;
  for (const auto& event : summary["liveness"]["events"]) {
    if (event["agent"] != 4) continue;
    if (event["event"] == "stalled" && stalled_at < 0) stalled_at = event["step"].get<long>();
    if (event["event"] == "resumed") resumed_at = event["step"].get<long>();
  }
  ASSERT_GE(stalled_at, 0) << summary["liveness"].dump();
  ASSERT_GT(resumed_at, stalled_at) << summary["liveness"].dump();
  const auto steps = scored_steps(dir, 4);
  for (const long step : steps) {
    EXPECT_FALSE(step >= stalled_at && step < resumed_at) << "scored at step " << step << " while stalled";
  }
  // 5 s at 10 Hz is 50 steps of silence; at most three periods of it may count an estimate as current.
  EXPECT_LE(static_cast<long>(steps.size()), 150 - 45) << "stale estimates were scored";
  EXPECT_EQ(agents_csv_cell(dir, 4, "fate"), "stalled");
}

TEST(RunIntegrity, ASecondRunOnTheSameDomainIsRefusedAndTheFirstEndsWithItsOwnResult) {
  const auto first_dir = fresh_directory("integrity-first");
  Child first(run_args(first_dir, 63, 8, 120),
              first_dir.parent_path() / (first_dir.filename().string() + ".log"));
  ASSERT_TRUE(first.wait_for_output(" step ", 60.0)) << first.output();

  for (const int agents : {10, 8}) {  // more agents than the first run, and as many (the port clash)
    const auto second_dir = fresh_directory("integrity-second-" + std::to_string(agents));
    Child second(run_args(second_dir, 63, agents, 40),
                 second_dir.parent_path() / (second_dir.filename().string() + ".log"));
    const auto code = second.wait(30.0);
    ASSERT_TRUE(code.has_value()) << second.output();
    EXPECT_EQ(*code, 1) << second.output();
    EXPECT_NE(second.output().find("dds.domain_id 63"), std::string::npos) << second.output();
    EXPECT_NE(second.output().find("--set dds.domain_id="), std::string::npos) << second.output();
    EXPECT_FALSE(std::filesystem::exists(second_dir / "summary.json"));
    EXPECT_EQ(count_processes_matching(second_dir.string()), 0);
  }

  const auto code = first.wait(90.0);
  ASSERT_TRUE(code.has_value()) << first.output();
  // Healthy or degraded by a loaded machine, never corrupted: every agent ran to the end, nobody died.
  EXPECT_TRUE(*code == 0 || *code == 3) << first.output();
  const auto summary = read_json(first_dir / "summary.json");
  EXPECT_EQ(summary["liveness"]["unscheduled_deaths"], 0);
  EXPECT_EQ(summary["final"]["step"], 119);
  EXPECT_EQ(summary["final"]["scored_agents"], 5);  // every non-anchor
  for (int agent = 0; agent < 8; ++agent) {
    EXPECT_GE(std::stol(agents_csv_cell(first_dir, agent, "steps_run")), 110)
        << "agent " << agent << " stopped early";
  }
}

TEST(RunIntegrity, TwoRunsWithMulticastDiscoveryOnOneDomainKeepTheirOwnSamples) {
  // Without fixed ports both runs start; the run id in every partition keeps them apart.
  const auto a_dir = fresh_directory("integrity-multicast-a");
  const auto b_dir = fresh_directory("integrity-multicast-b");
  auto a_args = run_args(a_dir, 64, 6, 60);
  auto b_args = run_args(b_dir, 64, 8, 40);
  for (auto* args : {&a_args, &b_args}) args->insert(args->end(), {"--set", "dds.neighbour_discovery=false"});
  Child a(a_args, a_dir.parent_path() / (a_dir.filename().string() + ".log"));
  Child b(b_args, b_dir.parent_path() / (b_dir.filename().string() + ".log"));
  const auto a_code = a.wait(120.0);
  const auto b_code = b.wait(120.0);
  ASSERT_TRUE(a_code && b_code) << a.output() << b.output();
  EXPECT_TRUE(*a_code == 0 || *a_code == 3) << a.output();
  EXPECT_TRUE(*b_code == 0 || *b_code == 3) << b.output();
  for (const auto& [dir, agents, steps] : {std::tuple{a_dir, 6, 60}, std::tuple{b_dir, 8, 40}}) {
    const auto summary = read_json(dir / "summary.json");
    EXPECT_EQ(summary["liveness"]["unscheduled_deaths"], 0);
    EXPECT_EQ(summary["final"]["scored_agents"], agents - 3) << dir;  // every non-anchor
    EXPECT_EQ(summary["final"]["step"], steps - 1) << dir;
    // Every link counted is one of this run's own: no sender outside its ids.
    const auto links = read_csv(dir / "links.csv");
    for (std::size_t r = 1; r < links.size(); ++r) {
      ASSERT_GE(links[r].size(), 2U);
      EXPECT_LT(std::stoi(links[r][0]), agents) << dir << ": a sample from another run's agent";
    }
  }
}

TEST(RunIntegrity, AnAgentWithAnotherScenarioIsRefusedAtHelloAndExits2) {
  const auto dir = fresh_directory("integrity-mismatch");
  auto args = run_args(dir, 65, 4, 30);
  args.insert(args.end(), {"--no-launch", "--set", "world.anchors=2", "--set", "run.startup_timeout_s=60"});
  Child run(args, dir.parent_path() / (dir.filename().string() + ".log"));
  const auto scenario = dir / "scenario.yaml";
  const auto give_up = Clock::now() + std::chrono::seconds(30);
  while (read_text(scenario).find("run_id") == std::string::npos && Clock::now() < give_up)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  auto agent = [&](int id, const std::vector<std::string>& extra, const std::string& tag) {
    std::vector<std::string> a{kBinary, "agent", "--scenario", scenario.string(), "--id", std::to_string(id)};
    a.insert(a.end(), extra.begin(), extra.end());
    return std::make_unique<Child>(a, dir.parent_path() / (dir.filename().string() + "-" + tag + ".log"));
  };
  std::vector<std::unique_ptr<Child>> honest;
  for (const int id : {0, 1, 3}) honest.push_back(agent(id, {}, "agent" + std::to_string(id)));
  // A forged manifest that agrees with its own scenario (seed 2): without it the agent would refuse
  // itself at once (the run's manifest has the run's results hash); with it, only hello catches it.
  const auto manifest = dir / "manifests" / "agent_002.json";
  while (!std::filesystem::exists(manifest) && Clock::now() < give_up)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  auto forged = swarmloc::runtime::load_manifest(manifest);
  forged.results_hash =
      swarmloc::config::results_hash(swarmloc::config::load_scenario(scenario.string(), {"seed=2"}));
  const auto forged_file = dir.parent_path() / (dir.filename().string() + "-forged.json");
  swarmloc::runtime::write_manifest(forged_file, forged);
  auto foreign = agent(2, {"--set", "seed=2", "--manifest", forged_file.string()}, "foreign");
  const auto foreign_code = foreign->wait(60.0);
  ASSERT_TRUE(foreign_code.has_value()) << "the foreign agent was not refused:\n" << foreign->output();
  EXPECT_EQ(*foreign_code, 2) << foreign->output();
  EXPECT_NE(foreign->output().find("refused by the orchestrator"), std::string::npos) << foreign->output();
  EXPECT_TRUE(run.wait_for_output("agent 2 refused", 10.0)) << run.output();

  // The right agent 2 is accepted, and the run completes with four agents scored.
  auto corrected = agent(2, {}, "agent2");
  const auto code = run.wait(120.0);
  ASSERT_TRUE(code.has_value()) << run.output();
  EXPECT_TRUE(*code == 0 || *code == 3) << run.output();
  const auto summary = read_json(dir / "summary.json");
  EXPECT_EQ(summary["final"]["scored_agents"], 2);  // 4 agents, 2 anchors
  ASSERT_TRUE(summary.contains("refused_agents"));
  EXPECT_EQ(summary["refused_agents"][0]["agent"], 2);
  EXPECT_EQ(corrected->wait(30.0), std::optional<int>(0)) << corrected->output();
}

void expect_complete_run_directory(const std::filesystem::path& dir) {
  for (const char* file :
       {"scenario.yaml", "seed", "summary.json", "metrics.csv", "estimates.csv", "links.csv", "agents.csv"}) {
    EXPECT_TRUE(std::filesystem::exists(dir / file)) << file;
  }
}

TEST(RunIntegrity, SighupEndsTheRunLikeSigtermWithACompleteRunDirectory) {
  const auto dir = fresh_directory("integrity-sighup");
  Child run(run_args(dir, 66, 6, 600), dir.parent_path() / (dir.filename().string() + ".log"));
  ASSERT_TRUE(run.wait_for_output(" step ", 60.0)) << run.output();
  ASSERT_EQ(::kill(run.pid(), SIGHUP), 0);
  const auto code = run.wait(30.0);
  ASSERT_TRUE(code.has_value()) << run.output();
  EXPECT_EQ(*code, 1) << "interrupted runs exit 1\n" << run.output();
  expect_complete_run_directory(dir);
  EXPECT_EQ(read_json(dir / "summary.json")["interrupted"], true);
  EXPECT_EQ(count_processes_matching(dir.string()), 0);
}

TEST(RunIntegrity, AClosedStdoutNeverKillsTheRun) {
  const auto dir = fresh_directory("integrity-sigpipe");
  Child run(run_args(dir, 67, 6, 30), dir.parent_path() / (dir.filename().string() + ".log"), true);
  const auto code = run.wait(90.0);
  ASSERT_TRUE(code.has_value()) << run.output();
  EXPECT_TRUE(*code == 0 || *code == 3) << "exit " << *code << " (141 = killed by SIGPIPE)\n" << run.output();
  expect_complete_run_directory(dir);
  EXPECT_EQ(read_json(dir / "summary.json")["interrupted"], false);
}

}  // namespace
}  // namespace run_integrity_test
