// Checked writes, summary.json last, a prepared --out, and no shell between a path and the programs we
// start (docs/robustness.md, "Outputs are complete or the run fails").
#include <gtest/gtest.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <vector>

#include "swarmloc/rundir/external_program.hpp"
#include "swarmloc/rundir/plots.hpp"
#include "swarmloc/rundir/run_record.hpp"
#include "swarmloc/runtime/output_file.hpp"
#include "swarmloc/sim/simulator.hpp"

namespace swarmloc::rundir {
namespace {

namespace fs = std::filesystem;

/// A fresh, empty temporary directory removed at the end of the test.
class TempDir {
 public:
  explicit TempDir(const std::string& name)
      : path_(fs::temp_directory_path() / ("swarmloc-output-" + name + "-" + std::to_string(::getpid()))) {
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  [[nodiscard]] const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Runs `body` in a child process under a file size limit of `limit` bytes (SIGXFSZ ignored, as in
/// main()): a write past it fails with EFBIG, like a full disk, without touching this process.
/// Returns the child's exit code.
int with_file_size_limit(rlim_t limit, const std::function<int()>& body) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    std::signal(SIGXFSZ, SIG_IGN);
    const rlimit rl{limit, limit};
    if (::setrlimit(RLIMIT_FSIZE, &rl) != 0) ::_exit(90);
    ::_exit(body());
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

/// A PNG ends with its IEND chunk.
bool whole_png(const fs::path& path) {
  const std::string bytes = read_text(path);
  const std::string iend("\0\0\0\0IEND\xae\x42\x60\x82", 12);
  return bytes.size() > iend.size() && bytes.compare(bytes.size() - iend.size(), iend.size(), iend) == 0;
}

RunRecord small_record() {
  config::Scenario s;
  s.seed = 5;
  s.world.agents = 8;
  s.world.anchors = 3;
  s.world.area_m = 20.0;
  s.world.comm_radius_m = 12.0;
  s.run.steps = 10;
  return sim::run_simulation(s);
}

std::string scenario_error(const std::function<void()>& action) {
  try {
    action();
  } catch (const config::ScenarioError& error) {
    return error.what();
  }
  ADD_FAILURE() << "expected a ScenarioError";
  return {};
}

// ---------------- checked writes ----------------

TEST(OutputIntegrity, AWriteToAFullDeviceThrowsNamingTheFileAndTheOsError) {
  try {
    runtime::write_text_file("/dev/full", "a line that cannot be stored\n");
    FAIL() << "a write to /dev/full succeeded";
  } catch (const runtime::OutputError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("/dev/full"), std::string::npos) << message;
    EXPECT_NE(message.find(std::strerror(ENOSPC)), std::string::npos) << message;
  }
  runtime::OutputFile file("/dev/full");
  file.write(std::string(100, 'x'));  // buffered: the failure shows at close
  EXPECT_THROW(file.close(), runtime::OutputError);
}

TEST(OutputIntegrity, AnAtomicWriteThatFailsLeavesNoTarget) {
  const TempDir dir("atomic");
  const auto target = dir.path() / "summary.json";
  const int code = with_file_size_limit(4096, [&] {
    try {
      runtime::write_text_file_atomic(target, std::string(64 * 1024, 'j'));
    } catch (const runtime::OutputError& error) {
      const std::string message = error.what();
      return message.find(std::strerror(EFBIG)) != std::string::npos &&
                     message.find("summary.json") != std::string::npos
                 ? 0
                 : 2;
    }
    return 1;
  });
  EXPECT_EQ(code, 0) << "1: no error; 2: the error did not name the file and EFBIG";
  EXPECT_FALSE(fs::exists(target));
}

TEST(OutputIntegrity, AnUnwritableTargetFailsTheRunDirectoryAndLeavesNoSummary) {
  const auto record = small_record();
  for (const std::string blocked : {"links.csv", "metrics.csv", "agents.csv", "plots"}) {
    const TempDir dir("blocked");
    // A directory where a file goes (or a file where plots/ goes): the open fails even for root.
    if (blocked == "plots") {
      runtime::write_text_file(dir.path() / blocked, "not a directory\n");
    } else {
      fs::create_directories(dir.path() / blocked);
    }
    try {
      write_run_directory(dir.path(), record);
      ADD_FAILURE() << "write_run_directory succeeded with " << blocked << " blocked";
    } catch (const runtime::OutputError& error) {
      EXPECT_NE(std::string(error.what()).find(blocked), std::string::npos) << error.what();
    }
    EXPECT_FALSE(fs::exists(dir.path() / "summary.json")) << blocked;
  }
}

TEST(OutputIntegrity, LargeEstimatesPastAFileSizeLimitFailTheRunDirectory) {
  const auto record = small_record();
  const TempDir dir("fsize");
  // scenario.yaml (3 KB) and the small CSVs fit in 4 KiB; estimates.csv (80 rows, 7 KB) does not.
  const int code = with_file_size_limit(4 * 1024, [&] {
    try {
      write_run_directory(dir.path(), record);
    } catch (const runtime::OutputError& error) {
      return std::string(error.what()).find("estimates.csv") != std::string::npos ? 0 : 2;
    }
    return 1;
  });
  EXPECT_EQ(code, 0) << "1: no error; 2: the error named another file";
  EXPECT_FALSE(fs::exists(dir.path() / "summary.json"));
}

TEST(OutputIntegrity, ACompleteRunDirectoryEndsWithItsSummary) {
  const auto record = small_record();
  const TempDir dir("complete");
  write_run_directory(dir.path(), record);
  const auto summary_time = fs::last_write_time(dir.path() / "summary.json");
  for (const auto& entry : fs::recursive_directory_iterator(dir.path())) {
    if (entry.is_regular_file()) {
      EXPECT_LE(entry.last_write_time(), summary_time) << entry.path();
    }
  }
  EXPECT_FALSE(fs::exists(dir.path() / "summary.json.partial"));
}

// ---------------- prepare_run_directory ----------------

TEST(PrepareRunDirectory, CreatesAMissingDirectoryAndAcceptsAnEmptyOne) {
  const TempDir dir("prepare-new");
  const auto nested = dir.path() / "a" / "b";
  prepare_run_directory(nested, false);
  EXPECT_TRUE(fs::is_directory(nested));
  EXPECT_TRUE(fs::is_empty(nested)) << "the writability probe was left behind";
  prepare_run_directory(nested, false);
}

TEST(PrepareRunDirectory, RefusesANonEmptyDirectoryWithoutForce) {
  const TempDir dir("prepare-earlier");
  runtime::write_text_file(dir.path() / "scenario.yaml", "name: earlier\n");
  const auto message = scenario_error([&] { prepare_run_directory(dir.path(), false); });
  EXPECT_NE(message.find("--out: " + dir.path().string() + " is not empty"), std::string::npos) << message;
  EXPECT_NE(message.find("--force"), std::string::npos) << message;
  EXPECT_TRUE(fs::exists(dir.path() / "scenario.yaml"));
}

TEST(PrepareRunDirectory, ForceClearsAnEarlierRun) {
  const TempDir dir("prepare-force");
  runtime::write_text_file(dir.path() / "summary.json", "{}\n");
  fs::create_directories(dir.path() / "logs");
  runtime::write_text_file(dir.path() / "logs" / "agent_0.log", "x\n");
  runtime::write_text_file(dir.path() / ".hidden", "x\n");
  prepare_run_directory(dir.path(), true);
  EXPECT_TRUE(fs::is_directory(dir.path()));
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

TEST(PrepareRunDirectory, ForceRefusesADirectoryThatIsNotARun) {
  const TempDir dir("prepare-other");
  runtime::write_text_file(dir.path() / "thesis.tex", "precious\n");
  const auto message = scenario_error([&] { prepare_run_directory(dir.path(), true); });
  EXPECT_NE(message.find("is not a swarmloc run directory; refusing to clear it"), std::string::npos)
      << message;
  EXPECT_EQ(read_text(dir.path() / "thesis.tex"), "precious\n");
}

TEST(PrepareRunDirectory, AnUnusablePathIsBadInputNamingIt) {
  const TempDir dir("prepare-bad");
  const auto file = dir.path() / "a-file";
  runtime::write_text_file(file, "x\n");
  // Root ignores permission bits, so these fail for everyone: a file as the directory or its parent,
  // and places the kernel does not let anyone create directories in.
  const std::vector<fs::path> unusable{file, file / "run", "/proc/swarmloc-no-such/run",
                                       "/sys/swarmloc-no-such-run"};
  for (const auto& path : unusable) {
    const auto message = scenario_error([&] { prepare_run_directory(path, false); });
    EXPECT_EQ(message.rfind("--out: " + path.string(), 0), 0u) << message;
  }
  EXPECT_NE(scenario_error([&] { prepare_run_directory(file / "run", false); }).find(std::strerror(ENOTDIR)),
            std::string::npos);
}

TEST(PrepareRunDirectory, AReadOnlyMountIsBadInput) {
  const TempDir dir("prepare-ro");
  if (::mount("swarmloc-test", dir.path().c_str(), "tmpfs", MS_RDONLY, "size=64k") != 0) {
    GTEST_SKIP() << "cannot mount a tmpfs here (" << std::strerror(errno)
                 << "); AnUnusablePathIsBadInputNamingIt covers the unwritable case";
  }
  const auto message = scenario_error([&] { prepare_run_directory(dir.path(), false); });
  ::umount(dir.path().c_str());
  EXPECT_NE(message.find("not writable"), std::string::npos) << message;
  EXPECT_NE(message.find(std::strerror(EROFS)), std::string::npos) << message;
}

TEST(DefaultRunDirectory, StaysDirectlyUnderRuns) {
  config::Scenario scenario;  // not validated: the directory must be safe even so
  const std::vector<std::string> names{"../../etc/cron.d/x", "/abs", "..", ".", std::string(300, 'n')};
  for (const auto& name : names) {
    scenario.name = name;
    const auto directory = default_run_directory(scenario);
    EXPECT_EQ(directory.parent_path(), fs::path("runs")) << name << " -> " << directory;
    EXPECT_LE(directory.filename().string().size(), 200u);
    EXPECT_NE(directory.filename().string().front(), '.') << directory;
  }
}

// ---------------- no shell ----------------

TEST(RunProgram, PassesArgumentsAsDataNotAsShellCode) {
  const TempDir dir("program");
  const std::string hostile =
      "x';touch INJECTED;' \"$(touch INJECTED2)\" `touch INJECTED3` ; touch INJECTED4";
  ProgramOptions options;
  options.working_directory = dir.path();
  options.stdout_path = dir.path() / "out.txt";
  const auto status = run_program({"printf", "%s", hostile}, options);
  ASSERT_TRUE(status.succeeded()) << status.describe();
  EXPECT_EQ(read_text(dir.path() / "out.txt"), hostile);
  for (const auto& entry : fs::directory_iterator(dir.path())) {
    EXPECT_EQ(entry.path().filename(), "out.txt") << "a shell ran: " << entry.path();
  }
}

TEST(RunProgram, ReportsExitStatusAndAProgramThatCannotStart) {
  const auto failed = run_program({"sh", "-c", "exit 3"});
  EXPECT_TRUE(failed.started);
  EXPECT_EQ(failed.exit_code, 3);
  EXPECT_FALSE(failed.succeeded());
  const auto missing = run_program({"swarmloc-no-such-program"});
  EXPECT_FALSE(missing.started);
  EXPECT_EQ(missing.start_error, ENOENT);
  EXPECT_NE(missing.describe().find("could not start"), std::string::npos);
  EXPECT_TRUE(find_program("sh").has_value());
  EXPECT_FALSE(find_program("swarmloc-no-such-program").has_value());
}

TEST(GnuplotQuote, DoublesSingleQuotes) {
  EXPECT_EQ(gnuplot_quote("it's"), "'it''s'");
  EXPECT_EQ(gnuplot_quote(""), "''");
}

TEST(Plots, AnOutPathWithQuotesSpacesAndShellCharactersGetsWholePngs) {
  if (!find_program("gnuplot")) GTEST_SKIP() << "gnuplot is not installed";
  const auto record = small_record();
  const TempDir dir("quotes");
  const auto out = dir.path() / "it's a $dir; `x` \"y\"";
  write_run_directory(out, record);
  for (const char* png : {"error.png", "nees.png", "positions.png", "error_histogram.png"}) {
    const auto path = out / "plots" / png;
    ASSERT_TRUE(fs::exists(path)) << path;
    EXPECT_GT(fs::file_size(path), 1000u) << path;
  }
  EXPECT_TRUE(fs::exists(out / "summary.json"));
}

TEST(Plots, APngThatDoesNotFitIsAFailedWrite) {
  if (!find_program("gnuplot")) GTEST_SKIP() << "gnuplot is not installed";
  const auto record = small_record();
  const TempDir complete("png-metrics");
  write_run_directory(complete.path(), record);  // the metrics.csv the scripts read
  const TempDir dir("png-full");
  // A tmpfs that holds metrics.csv, the plot data and scripts (the same files as in `complete`, in 4 KiB
  // pages) and 20 KiB more: gnuplot leaves a truncated error.png (about 45 KB), which must not pass for a
  // plot. Without mount rights: a file size limit (gnuplot inherits it).
  std::uintmax_t pages = 1;  // metrics.csv
  for (const auto& entry : fs::directory_iterator(complete.path() / "plots")) {
    if (entry.path().extension() != ".png") pages += (entry.file_size() + 4095) / 4096;
  }
  const std::string size = "size=" + std::to_string(pages * 4 + 20) + "k";
  if (::mount("swarmloc-test", dir.path().c_str(), "tmpfs", 0, size.c_str()) == 0) {
    fs::copy_file(complete.path() / "metrics.csv", dir.path() / "metrics.csv");
    std::string message;
    try {
      write_plots(dir.path(), record);
    } catch (const runtime::OutputError& error) {
      message = error.what();
    }
    // No truncated PNG stays behind to pass for a plot.
    for (const auto& entry : fs::directory_iterator(dir.path() / "plots")) {
      if (entry.path().extension() == ".png") {
        EXPECT_TRUE(whole_png(entry.path())) << entry.path();
      }
    }
    ::umount(dir.path().c_str());
    EXPECT_NE(message.find(".png"), std::string::npos) << "no failed write: '" << message << "'";
    EXPECT_NE(message.find(std::strerror(ENOSPC)), std::string::npos) << message;
    return;
  }
  fs::copy_file(complete.path() / "metrics.csv", dir.path() / "metrics.csv");
  const int code = with_file_size_limit(16 * 1024, [&] {
    try {
      write_plots(dir.path(), record);
    } catch (const runtime::OutputError& error) {
      const std::string message = error.what();
      return message.find(".png") != std::string::npos &&
                     message.find(std::strerror(EFBIG)) != std::string::npos
                 ? 0
                 : 2;
    }
    return 1;
  });
  EXPECT_EQ(code, 0) << "1: no error; 2: the error did not name a PNG and EFBIG";
}

}  // namespace
}  // namespace swarmloc::rundir
