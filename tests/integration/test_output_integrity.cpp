// Every run tells the truth about its outputs (docs/robustness.md, "Outputs are complete or the run fails"):
// a full disk ends `sim` and `run` with exit 1 naming the file and the OS error and without summary.json; an
// unusable --out is bad input (exit 2) before any work; names and paths with shell characters are data, never
// commands.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "process_helpers.hpp"

namespace output_integrity_test {
namespace {

namespace fs = std::filesystem;
using swarmloc::testing::fresh_directory;

const std::string kBinary = SWARMLOC_BINARY;
const std::string kScenario = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/ieif.yaml";

struct Outcome {
  int exit_code = -1;
  std::string output;  ///< stdout and stderr
};

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Runs swarmloc with `args` (no shell: every argument reaches it as written) in `cwd`, optionally under
/// a file size limit; stdout and stderr go to a log beside `cwd`.
Outcome swarmloc(const std::vector<std::string>& args, const fs::path& cwd,
                 std::optional<rlim_t> file_size_limit = std::nullopt, const std::string& binary = kBinary) {
  const auto log = cwd.parent_path() / (cwd.filename().string() + ".log");
  std::vector<std::string> argv{binary};
  argv.insert(argv.end(), args.begin(), args.end());
  const pid_t pid = ::fork();
  if (pid == 0) {
    if (::chdir(cwd.c_str()) != 0) ::_exit(120);
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd < 0) ::_exit(121);
    ::dup2(fd, STDOUT_FILENO);
    ::dup2(fd, STDERR_FILENO);
    if (file_size_limit) {
      const rlimit limit{*file_size_limit, *file_size_limit};
      if (::setrlimit(RLIMIT_FSIZE, &limit) != 0) ::_exit(122);
    }
    std::vector<char*> raw;
    for (auto& arg : argv) raw.push_back(arg.data());
    raw.push_back(nullptr);
    ::execv(raw[0], raw.data());
    ::_exit(127);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  Outcome outcome;
  outcome.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  outcome.output = read_text(log);
  return outcome;
}

/// A small tmpfs mounted for the test (root in CI); unmounted at the end.
class Tmpfs {
 public:
  Tmpfs(const fs::path& where, const std::string& options, unsigned long flags = 0) : where_(where) {
    fs::create_directories(where_);
    mounted_ = ::mount("swarmloc-test", where_.c_str(), "tmpfs", flags, options.c_str()) == 0;
    error_ = errno;
  }
  ~Tmpfs() {
    if (mounted_) ::umount2(where_.c_str(), MNT_DETACH);
  }
  Tmpfs(const Tmpfs&) = delete;
  Tmpfs& operator=(const Tmpfs&) = delete;
  [[nodiscard]] bool mounted() const { return mounted_; }
  [[nodiscard]] std::string why_not() const { return std::strerror(error_); }

 private:
  fs::path where_;
  bool mounted_ = false;
  int error_ = 0;
};

/// A disk that fills during the run: a 200 KB tmpfs with 64 KB left when it can be mounted, else a
/// file size limit of 8 KB on the process (EFBIG: the same failed write, one file at a time).
struct FullDisk {
  explicit FullDisk(const fs::path& base) : mount(base / "disk", "size=200k") {
    out = base / "disk" / "run";
    if (mount.mounted()) {
      std::ofstream(base / "disk" / "filler", std::ios::binary) << std::string(136 * 1024, 'f');
      os_error = std::strerror(ENOSPC);
    } else {
      limit = 8 * 1024;
      os_error = std::strerror(EFBIG);
    }
  }
  Tmpfs mount;
  fs::path out;
  std::optional<rlim_t> limit;
  std::string os_error;
};

void expect_failed_write(const Outcome& outcome, const FullDisk& disk) {
  EXPECT_EQ(outcome.exit_code, 1) << outcome.output;
  // "error: cannot write <run dir>/<file>: No space left on device"
  EXPECT_NE(outcome.output.find("error: cannot "), std::string::npos) << outcome.output;
  EXPECT_NE(outcome.output.find(disk.out.string() + "/"), std::string::npos) << outcome.output;
  EXPECT_NE(outcome.output.find(disk.os_error), std::string::npos) << outcome.output;
  EXPECT_FALSE(fs::exists(disk.out / "summary.json")) << "summary.json vouches for an incomplete directory";
}

TEST(OutputIntegrity, SimOnAFullDiskExitsOneNamingTheFileAndLeavesNoSummary) {
  const auto base = fresh_directory("full-sim");
  const FullDisk disk(base);
  if (!disk.mount.mounted())
    std::fprintf(stderr, "no tmpfs (%s): file size limit\n", disk.mount.why_not().c_str());
  // The CSVs fit in the 64 KB left, the twelve trajectory files (a 4 KiB page each) do not: the disk
  // fills after the point where an early summary.json would already be written, with or without gnuplot.
  const auto outcome = swarmloc({"sim", kScenario, "-q", "--out", disk.out.string(), "--set",
                                 "world.agents=6", "--set", "world.anchors=3", "--set", "run.steps=20"},
                                base, disk.limit);
  expect_failed_write(outcome, disk);
}

TEST(OutputIntegrity, RunOnAFullDiskExitsOneNamingTheFileAndLeavesNoSummary) {
  const auto base = fresh_directory("full-run");
  const FullDisk disk(base);
  const auto outcome = swarmloc(
      {"run", kScenario, "-q", "--out", disk.out.string(), "--set", "world.agents=6", "--set",
       "world.anchors=3", "--set", "run.steps=20", "--set", "run.rate_hz=20", "--set", "dds.domain_id=87"},
      base, disk.limit);
  expect_failed_write(outcome, disk);
}

TEST(OutputIntegrity, ShellCharactersInTheNameRunNothing) {
  const auto cwd = fresh_directory("injection");
  const auto outcome = swarmloc({"sim", kScenario, "-q", "--set", "name=x';touch INJECTED;'", "--set",
                                 "world.agents=6", "--set", "world.anchors=3", "--set", "run.steps=20"},
                                cwd);
  EXPECT_EQ(outcome.exit_code, 0) << outcome.output;
  int run_directories = 0;
  for (const auto& entry : fs::recursive_directory_iterator(cwd)) {
    EXPECT_NE(entry.path().filename(), "INJECTED") << "a shell ran the name";
    if (entry.is_directory() && entry.path().parent_path() == cwd / "runs") ++run_directories;
  }
  EXPECT_EQ(run_directories, 1) << "the run directory must be runs/<name>-…";
  EXPECT_FALSE(fs::exists(cwd.parent_path() / "INJECTED"));
}

TEST(OutputIntegrity, AnOutPathWithAnApostropheGetsWholePlots) {
  const auto cwd = fresh_directory("apostrophe");
  const auto out = cwd / "it's a run; $HOME";
  const auto outcome = swarmloc({"sim", kScenario, "-q", "--out", out.string(), "--set", "world.agents=6",
                                 "--set", "world.anchors=3", "--set", "run.steps=20"},
                                cwd);
  ASSERT_EQ(outcome.exit_code, 0) << outcome.output;
  EXPECT_TRUE(fs::exists(out / "summary.json"));
  if (outcome.output.find("gnuplot is not installed") != std::string::npos) GTEST_SKIP() << "no gnuplot";
  for (const char* png : {"error.png", "nees.png", "positions.png", "error_histogram.png"}) {
    ASSERT_TRUE(fs::exists(out / "plots" / png)) << png << "\n" << outcome.output;
    EXPECT_GT(fs::file_size(out / "plots" / png), 1000u) << png;
  }
}

TEST(OutputIntegrity, AnUnusableOutIsBadInputBeforeAnyWork) {
  const auto cwd = fresh_directory("unusable-out");
  std::ofstream(cwd / "a-file") << "x\n";
  std::vector<fs::path> unusable{"/proc/swarmloc-no-such/run", cwd / "a-file" / "run"};
  const Tmpfs read_only(cwd / "ro", "size=64k", MS_RDONLY);
  if (read_only.mounted()) unusable.push_back(cwd / "ro");
  for (const auto& out : unusable) {
    for (const char* command : {"sim", "run"}) {
      const auto outcome =
          swarmloc({command, kScenario, "-q", "--out", out.string(), "--set", "world.agents=6", "--set",
                    "world.anchors=3", "--set", "run.steps=20", "--set", "dds.domain_id=88"},
                   cwd);
      EXPECT_EQ(outcome.exit_code, 2) << command << " " << out << "\n" << outcome.output;
      EXPECT_NE(outcome.output.find("error: --out: " + out.string()), std::string::npos) << outcome.output;
      EXPECT_EQ(outcome.output.find("launched"), std::string::npos) << "agents started: " << outcome.output;
    }
  }
}

TEST(OutputIntegrity, ALongNameIsBadInputNotAnAbort) {
  const auto cwd = fresh_directory("long-name");
  for (const char* command : {"sim", "run"}) {
    const auto outcome = swarmloc({command, kScenario, "-q", "--set", "name=" + std::string(300, 'n')}, cwd);
    EXPECT_EQ(outcome.exit_code, 2) << command << "\n" << outcome.output;
    EXPECT_NE(outcome.output.find("error: name: "), std::string::npos) << outcome.output;
  }
}

TEST(OutputIntegrity, AnEarlierRunIsReplacedOnlyWithForce) {
  const auto cwd = fresh_directory("force");
  const auto out = cwd / "run";
  const std::vector<std::string> sim{"sim", kScenario, "-q", "--out", out.string(), "--set", "run.steps=5"};
  ASSERT_EQ(swarmloc(sim, cwd).exit_code, 0);
  const auto again = swarmloc(sim, cwd);
  EXPECT_EQ(again.exit_code, 2) << again.output;
  EXPECT_NE(again.output.find("pass --force"), std::string::npos) << again.output;
  auto forced = sim;
  forced.push_back("--force");
  const auto replaced = swarmloc(forced, cwd);
  EXPECT_EQ(replaced.exit_code, 0) << replaced.output;
  EXPECT_TRUE(fs::exists(out / "summary.json"));
}

TEST(Cli, AnUnknownCommandIsNamedWithTheListOfCommands) {
  const auto cwd = fresh_directory("cli-unknown");
  const auto outcome = swarmloc({"frobnicate"}, cwd);
  EXPECT_EQ(outcome.exit_code, 2);
  EXPECT_NE(outcome.output.find("'frobnicate'"), std::string::npos) << outcome.output;
  EXPECT_NE(outcome.output.find("run, sim"), std::string::npos) << outcome.output;
}

TEST(Cli, BadNumbersAreBadInputNamingTheFlag) {
  const auto cwd = fresh_directory("cli-numbers");
  const std::vector<std::vector<std::string>> bad{
      {"sim", kScenario, "--view-hold", "nan"},  {"sim", kScenario, "--view-hold", "-1"},
      {"run", kScenario, "--view-hold", "-inf"}, {"reproduce", "ea1", "--trials", "-3"},
      {"reproduce", "ea1", "--trials", "0"},     {"sim", kScenario, "--trials", "0"},
      {"sim", kScenario, "--trial", "-1"}};
  for (const auto& args : bad) {
    // The paper reproductions live in swarmloc-research, with the same flag rules.
    const std::string binary = args[0] == "reproduce" ? SWARMLOC_RESEARCH_BINARY : kBinary;
    const auto outcome = swarmloc(args, cwd, std::nullopt, binary);
    EXPECT_EQ(outcome.exit_code, 2) << args[2] << " " << args[3] << "\n" << outcome.output;
    EXPECT_NE(outcome.output.find(args[2]), std::string::npos) << outcome.output;
  }
}

/// The column `column` of trials.csv's row for `trial` in `directory`.
double trials_csv_value(const fs::path& directory, int trial, std::size_t column) {
  std::ifstream in(directory / "trials.csv");
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::stringstream row(line);
    for (std::string field; std::getline(row, field, ',');) fields.push_back(field);
    if (fields.size() > column && std::stoi(fields[0]) == trial) return std::stod(fields[column]);
  }
  return std::nan("");
}

TEST(Cli, OneTrialOfAMonteCarloSetIsItsRowRunInFull) {
  const auto cwd = fresh_directory("cli-trial");
  // Agent clocks and loss: the simulator that builds its own world and draws loss and latency per trial.
  std::vector<std::string> common{"sim", kScenario, "-q"};
  for (const char* key : {"run.steps=12", "run.sim_clock=agents", "network.loss=0.2", "network.jitter_ms=40"})
    common.insert(common.end(), {"--set", key});
  auto monte_carlo = common;
  monte_carlo.insert(monte_carlo.end(), {"--trials", "3", "--out", (cwd / "mc").string()});
  ASSERT_EQ(swarmloc(monte_carlo, cwd).exit_code, 0);
  for (const int trial : {0, 2}) {
    auto single = common;
    const auto out = cwd / ("trial" + std::to_string(trial));
    single.insert(single.end(), {"--trial", std::to_string(trial), "--out", out.string()});
    const auto outcome = swarmloc(single, cwd);
    ASSERT_EQ(outcome.exit_code, 0) << outcome.output;
    const auto summary = nlohmann::json::parse(read_text(out / "summary.json"));
    const double row_rmse = trials_csv_value(cwd / "mc", trial, 1);
    EXPECT_NEAR(summary["final"]["rmse_m"].get<double>(), row_rmse, 1e-8 * row_rmse) << "trial " << trial;
    EXPECT_EQ(summary.contains("trial"), trial > 0) << "the first trial is the plain run";
    EXPECT_TRUE(fs::exists(out / "estimates.csv"));
  }
  EXPECT_NE(trials_csv_value(cwd / "mc", 0, 1), trials_csv_value(cwd / "mc", 2, 1)) << "trials differ";
  auto both = common;
  both.insert(both.end(), {"--trial", "1", "--trials", "3", "--out", (cwd / "both").string()});
  const auto refused = swarmloc(both, cwd);
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  EXPECT_NE(refused.output.find("--trial"), std::string::npos) << refused.output;
  // Over DDS a fusion centre builds the first trial's world: another trial is refused, not run wrong.
  const auto centralized = swarmloc({"run", std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/ea2.yaml", "-q",
                                     "--trial", "1", "--out", (cwd / "centralized").string()},
                                    cwd);
  EXPECT_EQ(centralized.exit_code, 2) << centralized.output;
  EXPECT_NE(centralized.output.find("--trial"), std::string::npos) << centralized.output;
}

}  // namespace
}  // namespace output_integrity_test
