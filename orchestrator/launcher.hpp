#pragma once
// Starts and reaps local agent processes. Every child gets PR_SET_PDEATHSIG=SIGKILL, so no agent
// outlives the orchestrator, even when the orchestrator itself is killed with SIGKILL.
#include <sys/types.h>

#include <optional>
#include <string>
#include <vector>

namespace swarmloc::orchestrator {

class ProcessLauncher {
 public:
  ProcessLauncher() = default;
  ~ProcessLauncher();  ///< kills whatever is still running
  ProcessLauncher(const ProcessLauncher&) = delete;
  ProcessLauncher& operator=(const ProcessLauncher&) = delete;

  /// Starts `argv[0]` with `argv`; stdout/stderr go to `output_path` (appended). The child runs at our
  /// nice value + nice_increment (every thread it starts inherits it). Returns the index.
  int launch(const std::vector<std::string>& argv, const std::string& output_path, int nice_increment = 0);

  /// Non-blocking reap; returns how many are still running.
  int poll();
  /// SIGTERM to all running, wait up to grace_s, then SIGKILL the rest and reap.
  void stop_all(double grace_s);
  void kill(int index, int signal);

  [[nodiscard]] int size() const { return static_cast<int>(children_.size()); }
  [[nodiscard]] pid_t pid(int index) const { return children_.at(static_cast<std::size_t>(index)).pid; }
  [[nodiscard]] bool running(int index) const {
    return children_.at(static_cast<std::size_t>(index)).running;
  }
  /// Exit code (or 128 + signal) once reaped.
  [[nodiscard]] std::optional<int> exit_code(int index) const {
    return children_.at(static_cast<std::size_t>(index)).exit_code;
  }

 private:
  struct Child {
    pid_t pid = -1;
    bool running = false;
    std::optional<int> exit_code;
  };
  void record_exit(Child& child, int status);
  std::vector<Child> children_;
};

}  // namespace swarmloc::orchestrator
