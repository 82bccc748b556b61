#pragma once
// Reading what tests/ros2_reader prints (its line formats are documented there): one record per line, the
// record's kind first, and the stamps as ROS 2 times (sec, nanosec).
#include <cstdint>
#include <sstream>
#include <string>

namespace swarmloc::testing {

/// Calls on_line(kind, rest) for every line of `text`, `rest` positioned after the kind.
template <typename OnLine>
void for_each_ros2_reader_line(const std::string& text, OnLine on_line) {
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    std::istringstream in(line);
    std::string kind;
    in >> kind;
    on_line(kind, in);
  }
}

/// The next "sec nanosec" of `in` as nanoseconds.
inline std::int64_t read_ros2_stamp_ns(std::istringstream& in) {
  std::int64_t sec = 0;
  std::uint64_t nanosec = 0;
  in >> sec >> nanosec;
  return sec * 1'000'000'000 + static_cast<std::int64_t>(nanosec);
}

}  // namespace swarmloc::testing
