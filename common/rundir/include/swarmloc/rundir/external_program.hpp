#pragma once
// Starting another program (gnuplot) without a shell: the arguments go to the program as they are, so
// a path or a scenario name holding quotes, spaces, `$` or `;` is data, never a command
// (docs/robustness.md, "Outputs are complete or the run fails").
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace swarmloc::rundir {

struct ProgramOptions {
  std::filesystem::path working_directory;  ///< empty: this process's
  /// Redirections; nullopt inherits this process's stream ("/dev/null" discards).
  std::optional<std::filesystem::path> stdin_path;
  std::optional<std::filesystem::path> stdout_path;
  std::optional<std::filesystem::path> stderr_path;
};

struct ProgramStatus {
  bool started = false;  ///< false: not found, not executable, or a redirection failed (start_error)
  int start_error = 0;   ///< errno when !started
  int exit_code = -1;    ///< the exit status when it exited
  int signal = 0;        ///< the signal that ended it, else 0

  [[nodiscard]] bool succeeded() const { return started && signal == 0 && exit_code == 0; }
  /// "exited with 1", "killed by signal 9", "could not start: No such file or directory".
  [[nodiscard]] std::string describe() const;
};

/// Runs argv[0] (searched on PATH unless it holds a '/') with argv, waits for it and returns how it ended.
/// Throws std::invalid_argument if argv is empty.
ProgramStatus run_program(const std::vector<std::string>& argv, const ProgramOptions& options = {});

/// The executable `name` on PATH, as a shell's `command -v` would find it; nullopt if there is none.
std::optional<std::filesystem::path> find_program(std::string_view name);

}  // namespace swarmloc::rundir
