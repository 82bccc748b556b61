#include "launcher.hpp"

#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <stdexcept>
#include <thread>

#include "swarmloc/runtime/world_pacing.hpp"

namespace swarmloc::orchestrator {

ProcessLauncher::~ProcessLauncher() { stop_all(0.5); }

namespace {

std::vector<char*> c_strings(const std::vector<std::string>& strings) {
  std::vector<char*> pointers;
  pointers.reserve(strings.size() + 1);
  for (const auto& s : strings) pointers.push_back(const_cast<char*>(s.c_str()));
  pointers.push_back(nullptr);
  return pointers;
}

}  // namespace

int ProcessLauncher::launch(const std::vector<std::string>& argv, const std::string& output_path,
                            int nice_increment) {
  const std::vector<char*> args = c_strings(argv);  // built in the parent: after fork() only exec is safe
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error(std::string("fork failed: ") + std::strerror(errno));
  if (pid == 0) {
    // Child: die with the parent, even if the parent is SIGKILLed.
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != parent) _exit(1);    // parent already gone
    runtime::lower_to_normal_priority();  // the world loop may run at real-time priority; agents do not
    // Lower than the orchestrator (run.agent_nice); if the kernel refuses, the child keeps ours.
    if (nice_increment > 0) {
      setpriority(PRIO_PROCESS, 0, std::min(19, getpriority(PRIO_PROCESS, 0) + nice_increment));
    }
    const int fd = open(output_path.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (fd >= 0) {
      dup2(fd, STDOUT_FILENO);
      dup2(fd, STDERR_FILENO);
      close(fd);
    }
    const int null_fd = open("/dev/null", O_RDONLY);
    if (null_fd >= 0) dup2(null_fd, STDIN_FILENO);
    execv(args[0], args.data());
    _exit(127);
  }
  children_.push_back(Child{pid, true, std::nullopt});
  return static_cast<int>(children_.size()) - 1;
}

void ProcessLauncher::record_exit(Child& child, int status) {
  child.running = false;
  if (WIFEXITED(status))
    child.exit_code = WEXITSTATUS(status);
  else if (WIFSIGNALED(status))
    child.exit_code = 128 + WTERMSIG(status);
}

int ProcessLauncher::poll() {
  int alive = 0;
  for (auto& child : children_) {
    if (!child.running) continue;
    int status = 0;
    const pid_t r = waitpid(child.pid, &status, WNOHANG);
    if (r == child.pid)
      record_exit(child, status);
    else if (r < 0 && errno == ECHILD)
      child.running = false;
    else
      ++alive;
  }
  return alive;
}

void ProcessLauncher::kill(int index, int signal) {
  auto& child = children_.at(static_cast<std::size_t>(index));
  if (child.running) ::kill(child.pid, signal);
}

void ProcessLauncher::stop_all(double grace_s) {
  if (poll() == 0) return;
  for (auto& child : children_) {
    if (child.running) ::kill(child.pid, SIGTERM);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(grace_s);
  while (poll() > 0 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  for (auto& child : children_) {
    if (!child.running) continue;
    ::kill(child.pid, SIGKILL);
    int status = 0;
    if (waitpid(child.pid, &status, 0) == child.pid) record_exit(child, status);
    child.running = false;
  }
}

}  // namespace swarmloc::orchestrator
