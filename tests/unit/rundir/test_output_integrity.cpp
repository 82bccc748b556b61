// Checked writes, an atomic summary.json, a prepared --out, and no shell between a path and the programs we
// start (docs/robustness.md, "Outputs are complete or the run fails"). A simulated run's whole run directory
// (summary.json last, a blocked or full target, whole PNGs): tests/unit/sim/test_simulated_run_directory.cpp.
#include <gtest/gtest.h>
#include <sys/mount.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "process_helpers.hpp"
#include "swarmloc/rundir/external_program.hpp"
#include "swarmloc/rundir/plots.hpp"
#include "swarmloc/rundir/run_record.hpp"
#include "swarmloc/runtime/output_file.hpp"

namespace swarmloc::rundir {
namespace {

namespace fs = std::filesystem;

using testing::read_text;
using testing::TempDir;
using testing::with_file_size_limit;

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

}  // namespace
}  // namespace swarmloc::rundir
