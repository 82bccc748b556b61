#pragma once
// What the reproduction experiments (reproduce_0*.cpp) share: threads, output, number formatting, and the
// papers' reference numbers (research/data/reference/*.csv, embedded at build time).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "reproduce.hpp"

namespace swarmloc::research::reproduce_detail {

/// `threads`, or every core when it is 0.
int resolve_threads(int threads);

/// Runs fn(trial) for trial in [0, trials) on `threads` threads.
template <typename Fn>
void parallel_trials(int trials, int threads, Fn&& fn) {
  std::atomic<int> next{0};
  const int count = resolve_threads(threads);
  std::vector<std::thread> pool;
  pool.reserve(static_cast<std::size_t>(count));
  for (int k = 0; k < count; ++k) {
    pool.emplace_back([&] {
      for (int t = next++; t < trials; t = next++) fn(t);
    });
  }
  for (auto& thread : pool) thread.join();
}

/// Writes `markdown` to out_dir/name.md and prints it.
void emit(const std::filesystem::path& out_dir, const std::string& name, const std::string& markdown);

/// snprintf of one number.
std::string fmt(const char* format, double value);

/// Wall-clock seconds since `started`.
double seconds_since(std::chrono::steady_clock::time_point started);

/// One of the papers' reference tables, research/data/reference/<name>.csv: a header row, then rows of
/// comma-separated fields ('#' lines are comments).
class ReferenceTable {
 public:
  /// The table of that name (e.g. "001_table1"); throws std::logic_error if there is none.
  static const ReferenceTable& get(const std::string& name);

  std::size_t rows() const { return rows_.size(); }
  const std::string& text(std::size_t row, const std::string& column) const;
  /// The field as a number; `if_empty` when the field is empty (the paper does not report it).
  double number(std::size_t row, const std::string& column, double if_empty = 0.0) const;

  static ReferenceTable parse(const std::string& name, const std::string& csv);

 private:
  std::string name_;
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
};

// The experiments, one per `swarmloc-research reproduce` name (reproduce.cpp dispatches).
int reproduce_ea1(const ReproduceOptions& options);
int reproduce_ea2(const ReproduceOptions& options);
int reproduce_ea3(const ReproduceOptions& options);
/// Gasparri & Pascucci Table I or II: `table` names the reference table (001_table1, 001_table2).
int reproduce_kalman_table(const ReproduceOptions& options, const std::string& name, const std::string& table,
                           const std::string& title);
int reproduce_jacobi(const ReproduceOptions& options);
int reproduce_tracking(const ReproduceOptions& options);
int reproduce_joint_field(const ReproduceOptions& options);
int reproduce_multipath(const ReproduceOptions& options);
int reproduce_dgbb_table1(const ReproduceOptions& options);
int reproduce_dgbb_figures(const ReproduceOptions& options);
int reproduce_dgbb_table2(const ReproduceOptions& options);
int reproduce_dgbb_table3(const ReproduceOptions& options);

}  // namespace swarmloc::research::reproduce_detail
