#pragma once
// What both command lines, `swarmloc` and `swarmloc-research`, need from the process and from CLI11.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <array>
#include <cerrno>
#include <climits>
#include <cstdlib>
#include <filesystem>
#include <string>

namespace swarmloc::orchestrator {

/// The running executable's path (/proc/self/exe; argv[0] made absolute where that is unreadable).
inline std::filesystem::path self_executable(const char* argv0) {
  std::array<char, 4096> buffer{};
  const ssize_t length = readlink("/proc/self/exe", buffer.data(), buffer.size() - 1);
  if (length > 0) return std::string(buffer.data(), static_cast<std::size_t>(length));
  return std::filesystem::absolute(argv0);
}

/// CLI::PositiveNumber's message prints the double range 0 to 1.8e308; this one says what is wanted.
inline const CLI::Validator kPositiveInteger(
    [](const std::string& text) -> std::string {
      char* end = nullptr;
      errno = 0;
      const long value = std::strtol(text.c_str(), &end, 10);
      if (end != text.c_str() && *end == '\0' && errno == 0 && value >= 1 && value <= INT_MAX) return {};
      return "'" + text + "' must be a positive integer";
    },
    "INT >= 1");

}  // namespace swarmloc::orchestrator
