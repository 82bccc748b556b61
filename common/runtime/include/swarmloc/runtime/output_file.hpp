#pragma once
// Checked output: every write of a run's files goes through here, so a full disk, a read-only mount or
// a vanished directory ends the run with the file's name and the OS error instead of a silently short
// file (docs/robustness.md, "Outputs are complete or the run fails").
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>

namespace swarmloc::runtime {

/// A write that failed: names the file and the OS error (e.g. "No space left on device").
class OutputError : public std::runtime_error {
 public:
  OutputError(const std::filesystem::path& path, const std::string& what_failed, int os_error);
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

/// A file written front to back. Every write is checked; close() flushes and reports what the kernel
/// refused (ENOSPC often shows only at flush or close). Destroying an unclosed file closes it quietly.
class OutputFile {
 public:
  explicit OutputFile(std::filesystem::path path, bool append = false);
  ~OutputFile();
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  void write(std::string_view bytes);
  void write(const void* data, std::size_t size);
  void close();
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  std::FILE* file_ = nullptr;
};

/// The whole file at once.
void write_text_file(const std::filesystem::path& path, std::string_view text);
/// Temporary file in the same directory, fsync, then rename: readers see the old file or the whole new
/// one, never a part (summary.json, whose presence marks a complete run directory).
void write_text_file_atomic(const std::filesystem::path& path, std::string_view text);

}  // namespace swarmloc::runtime
