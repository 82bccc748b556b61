#include "swarmloc/runtime/output_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

namespace swarmloc::runtime {

OutputError::OutputError(const std::filesystem::path& path, const std::string& what_failed, int os_error)
    : std::runtime_error("cannot " + what_failed + " " + path.string() + ": " + std::strerror(os_error)),
      path_(path) {}

OutputFile::OutputFile(std::filesystem::path path, bool append) : path_(std::move(path)) {
  file_ = std::fopen(path_.c_str(), append ? "ab" : "wb");
  if (file_ == nullptr) throw OutputError(path_, "create", errno);
}

OutputFile::~OutputFile() {
  if (file_ != nullptr) std::fclose(file_);
}

void OutputFile::write(std::string_view bytes) { write(bytes.data(), bytes.size()); }

void OutputFile::write(const void* data, std::size_t size) {
  if (file_ == nullptr) throw OutputError(path_, "write (already closed)", EBADF);
  if (size == 0) return;
  if (std::fwrite(data, 1, size, file_) != size) throw OutputError(path_, "write", errno);
}

void OutputFile::close() {
  if (file_ == nullptr) return;
  std::FILE* file = std::exchange(file_, nullptr);
  const bool flushed = std::fflush(file) == 0;
  const int flush_error = errno;
  const bool closed = std::fclose(file) == 0;
  if (!flushed) throw OutputError(path_, "write", flush_error);
  if (!closed) throw OutputError(path_, "close", errno);
}

void write_text_file(const std::filesystem::path& path, std::string_view text) {
  OutputFile file(path);
  file.write(text);
  file.close();
}

void write_text_file_atomic(const std::filesystem::path& path, std::string_view text) {
  const auto temporary = std::filesystem::path(path.string() + ".partial");
  {
    OutputFile file(temporary);
    file.write(text);
    file.close();
  }
  const int fd = ::open(temporary.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0 || ::fsync(fd) != 0) {
    const int error = errno;
    if (fd >= 0) ::close(fd);
    throw OutputError(temporary, "sync", error);
  }
  ::close(fd);
  if (std::rename(temporary.c_str(), path.c_str()) != 0) {
    const int error = errno;
    std::remove(temporary.c_str());
    throw OutputError(path, "rename " + temporary.string() + " to", error);
  }
}

}  // namespace swarmloc::runtime
