#pragma once
// `swarmloc reproduce <experiment>`: runs a paper experiment and writes a Markdown table with the
// paper's numbers beside ours (and CSV data) into the output directory.
#include <filesystem>
#include <string>
#include <vector>

namespace swarmloc::research {

struct ReproduceOptions {
  std::string experiment;
  std::filesystem::path out_dir;
  int trials = 0;   ///< 0: the experiment's default (the paper's count)
  int threads = 0;  ///< 0: every core
  std::uint64_t seed = 1;
};

/// Experiments: ea1, ea2, ea3 (Khan et al.), ieif-table1, ieif-table2 (Gasparri & Pascucci), jacobi-002,
/// joint-field-002, tracking-002, multipath-003, dgbb-004-table1, dgbb-004-figs, dgbb-004-table2,
/// dgbb-004-table3.
const std::vector<std::string>& known_experiments();

/// Returns the exit code (2 for an unknown experiment).
int run_reproduce(const ReproduceOptions& options);

/// The Gasparri & Pascucci Table I/II statistics of one configuration (exposed for tests).
struct KalmanTableColumn {
  double max_error_cm = 0.0, min_error_cm = 0.0, mean_error_cm = 0.0, std_error_cm = 0.0;
  double convergence_step = 0.0;
  double failure_percent = 0.0;
  int trials = 0;
};
KalmanTableColumn run_kalman_table_column(const std::string& algorithm, int agents, int anchors,
                                          double noise_std_m, int trials, int threads, std::uint64_t seed);

}  // namespace swarmloc::research
