#include "swarmloc/rundir/external_program.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

extern char** environ;

namespace swarmloc::rundir {
namespace {

/// Owns a posix_spawn_file_actions_t.
class FileActions {
 public:
  FileActions() { posix_spawn_file_actions_init(&actions_); }
  ~FileActions() { posix_spawn_file_actions_destroy(&actions_); }
  FileActions(const FileActions&) = delete;
  FileActions& operator=(const FileActions&) = delete;
  posix_spawn_file_actions_t* get() { return &actions_; }

 private:
  posix_spawn_file_actions_t actions_{};
};

}  // namespace

std::string ProgramStatus::describe() const {
  if (!started) return std::string("could not start: ") + std::strerror(start_error);
  if (signal != 0) return "killed by signal " + std::to_string(signal);
  return "exited with " + std::to_string(exit_code);
}

ProgramStatus run_program(const std::vector<std::string>& argv, const ProgramOptions& options) {
  if (argv.empty()) throw std::invalid_argument("run_program: empty argv");
  std::vector<char*> args;
  args.reserve(argv.size() + 1);
  for (const auto& arg : argv) args.push_back(const_cast<char*>(arg.c_str()));
  args.push_back(nullptr);

  ProgramStatus status;
  FileActions actions;
  // posix_spawn, not fork: safe in a process with threads (DDS, worker pools), and exec errors come back
  // as the return value rather than as a child exit code.
  int error = 0;
  if (!options.working_directory.empty()) {
    error = posix_spawn_file_actions_addchdir_np(actions.get(), options.working_directory.c_str());
  }
  const auto redirect = [&](int fd, const std::optional<std::filesystem::path>& path, int flags) {
    if (error == 0 && path)
      error = posix_spawn_file_actions_addopen(actions.get(), fd, path->c_str(), flags, 0644);
  };
  redirect(STDIN_FILENO, options.stdin_path, O_RDONLY);
  redirect(STDOUT_FILENO, options.stdout_path, O_WRONLY | O_CREAT | O_TRUNC);
  redirect(STDERR_FILENO, options.stderr_path, O_WRONLY | O_CREAT | O_TRUNC);
  if (error != 0) {
    status.start_error = error;
    return status;
  }
  // The child starts with no signal blocked, whatever this thread blocks.
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  sigset_t none;
  sigemptyset(&none);
  posix_spawnattr_setsigmask(&attributes, &none);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETSIGMASK);
  pid_t pid = -1;
  error = posix_spawnp(&pid, args[0], actions.get(), &attributes, args.data(), environ);
  posix_spawnattr_destroy(&attributes);
  if (error != 0) {
    status.start_error = error;
    return status;
  }
  status.started = true;
  int wait_status = 0;
  while (::waitpid(pid, &wait_status, 0) < 0) {
    if (errno != EINTR) return status;  // reaped elsewhere: exit_code stays -1
  }
  if (WIFEXITED(wait_status)) status.exit_code = WEXITSTATUS(wait_status);
  if (WIFSIGNALED(wait_status)) status.signal = WTERMSIG(wait_status);
  return status;
}

std::optional<std::filesystem::path> find_program(std::string_view name) {
  if (name.empty()) return std::nullopt;
  auto executable = [](const std::filesystem::path& path) {
    struct stat info {};
    return ::stat(path.c_str(), &info) == 0 && S_ISREG(info.st_mode) && ::access(path.c_str(), X_OK) == 0;
  };
  if (name.find('/') != std::string_view::npos) {
    const std::filesystem::path path(name);
    return executable(path) ? std::optional(path) : std::nullopt;
  }
  const char* path_variable = std::getenv("PATH");
  const std::string_view search = path_variable != nullptr ? path_variable : "/usr/local/bin:/usr/bin:/bin";
  std::size_t begin = 0;
  while (begin <= search.size()) {
    const auto end = std::min(search.find(':', begin), search.size());
    const auto directory = search.substr(begin, end - begin);
    const auto candidate = std::filesystem::path(directory.empty() ? "." : directory) / name;
    if (executable(candidate)) return candidate;
    begin = end + 1;
  }
  return std::nullopt;
}

}  // namespace swarmloc::rundir
