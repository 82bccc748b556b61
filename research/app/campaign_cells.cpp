#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>

#include "campaign_internal.hpp"
#include "orchestrator.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/runtime/output_file.hpp"
#include "swarmloc/sim/simulator.hpp"

namespace swarmloc::research {
namespace campaign_detail {
namespace {

double json_number(const nlohmann::json& value) { return value.is_number() ? value.get<double>() : kNaN; }

/// Fills the figures of `result` from a run's summary.json and per-step RMSE.
void measure(RunResult& result, const nlohmann::json& summary, const std::vector<RmseSample>& steps,
             double rate_hz) {
  if (steps.empty()) {
    result.ok = false;
    result.error = "no scored step";
    return;
  }
  result.final_rmse_m = steps.back().missing == 0 ? steps.back().rmse_m : kNaN;
  if (steps.back().missing != 0) {
    result.ok = false;
    result.error = std::to_string(steps.back().missing) + " agents without an estimate at the last step";
  }
  result.crlb_rmse_m = json_number(
      summary.value("crlb", nlohmann::json::object()).value("accumulated_rmse_m", nlohmann::json()));
  const auto bound = summary.value("bound", nlohmann::json::object());
  result.bound_rmse_m = json_number(bound.value("rmse_m", nlohmann::json()));
  result.bound_kind = bound.value("kind", std::string());
  result.converge_step = converge_step(steps);
  result.still_falling = still_falling(steps);
  result.converge_s = result.converge_step >= 0 ? static_cast<double>(result.converge_step) / rate_hz : kNaN;
  const auto links = summary.value("links", nlohmann::json::object());
  result.sent = links.value("sent", std::uint64_t{0});
  result.delivered = links.value("delivered", std::uint64_t{0});
  result.dropped_injected = links.value("dropped_injected", std::uint64_t{0});
}

void write_metrics_csv(const std::filesystem::path& path, const rundir::RunRecord& record) {
  std::ostringstream out;
  out << "step,time_s,rmse_m,mean_error_m,max_error_m,crlb_rmse_m,nees,scored,missing\n"
      << std::setprecision(9);
  for (const auto& m : record.metrics) {
    out << m.step << ',' << m.time_s << ',' << m.errors.rmse_m << ',' << m.errors.mean_error_m << ','
        << m.errors.max_error_m << ',' << m.crlb_rmse_m << ',' << m.errors.nees << ',' << m.errors.scored
        << ',' << m.errors.missing << '\n';
  }
  runtime::write_text_file(path, out.str());
}

/// Per-step RMSE and missing count from a run directory's metrics.csv.
std::vector<RmseSample> read_metrics_csv(const std::filesystem::path& path) {
  std::vector<RmseSample> steps;
  std::ifstream in(path);
  std::string line;
  std::getline(in,
               line);  // header: step,time_s,rmse_m,mean_error_m,max_error_m,crlb_rmse_m,nees,scored,missing
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::stringstream row(line);
    for (std::string field; std::getline(row, field, ',');) fields.push_back(field);
    if (fields.size() < 9) continue;
    steps.push_back({std::strtod(fields[2].c_str(), nullptr), std::atoi(fields[8].c_str())});
  }
  return steps;
}

/// Sends stdout (the orchestrator's log lines and result table) to a file while a DDS cell runs, so
/// the campaign's own output stays readable; restored on destruction.
class StdoutToFile {
 public:
  explicit StdoutToFile(const std::filesystem::path& path) {
    std::fflush(stdout);
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd < 0) return;
    saved_ = ::dup(STDOUT_FILENO);
    ::dup2(fd, STDOUT_FILENO);
    ::close(fd);
  }
  ~StdoutToFile() {
    if (saved_ < 0) return;
    std::fflush(stdout);
    ::dup2(saved_, STDOUT_FILENO);
    ::close(saved_);
  }
  StdoutToFile(const StdoutToFile&) = delete;
  StdoutToFile& operator=(const StdoutToFile&) = delete;

 private:
  int saved_ = -1;
};

}  // namespace

/// A simulator cell: in-process, writing a slim run directory (scenario.yaml, summary.json,
/// metrics.csv; no per-agent estimates or plots, which would dominate the campaign's cost).
void run_sim_cell(const CampaignSpec& spec, RunResult& result) {
  const auto started = Clock::now();
  try {
    const auto scenario = config::load_scenario(
        spec.algorithms[result.algorithm].scenario.string(),
        cell_overrides(spec, result.algorithm, result.variant, result.value, result.seed));
    sim::SimOptions options;
    options.record_estimates = false;
    auto record = sim::run_simulation(scenario, options);
    record.wall_s = seconds_since(started);
    rundir::create_output_directories(result.run_dir);
    runtime::write_text_file(result.run_dir / "scenario.yaml", config::to_yaml(scenario));
    const auto summary = rundir::summary_json(record);
    write_metrics_csv(result.run_dir / "metrics.csv", record);
    // Last and atomic, as in a full run directory: its presence means the cell's files are complete.
    runtime::write_text_file_atomic(result.run_dir / "summary.json", summary.dump(2) + "\n");
    std::vector<RmseSample> steps;
    for (const auto& m : record.metrics) steps.push_back({m.errors.rmse_m, m.errors.missing});
    result.ok = true;
    measure(result, summary, steps, scenario.run.rate_hz);
  } catch (const std::exception& error) {
    result.ok = false;
    result.error = error.what();
  }
  result.wall_s = seconds_since(started);
}

/// A DDS cell: the same code path as `swarmloc run` (orchestrator in this process, one agent process
/// per agent), then its run directory is read back.
void run_dds_cell(const CampaignSpec& spec, RunResult& result, const std::string& agent_binary,
                  bool& interrupted) {
  const auto started = Clock::now();
  orchestrator::RunOptions options;
  options.scenario_path = spec.algorithms[result.algorithm].scenario.string();
  options.overrides = cell_overrides(spec, result.algorithm, result.variant, result.value, result.seed);
  options.out_dir = result.run_dir;
  options.agent_binary = agent_binary;
  options.progress = false;
  // The orchestrator wants an empty run directory: its output goes beside it first, then inside.
  std::error_code ec;
  std::filesystem::create_directories(result.run_dir.parent_path(), ec);
  const auto log = result.run_dir.parent_path() / (result.run_dir.filename().string() + ".orchestrator.out");
  int code = 1;
  {
    StdoutToFile redirect(log);
    code = orchestrator::run_orchestrator(options);
  }
  std::filesystem::create_directories(result.run_dir, ec);
  std::filesystem::rename(log, result.run_dir / "orchestrator.out", ec);
  result.wall_s = seconds_since(started);
  try {
    nlohmann::json summary;
    std::ifstream(result.run_dir / "summary.json") >> summary;
    interrupted = summary.value("interrupted", false);
    const auto scenario = config::load_scenario((result.run_dir / "scenario.yaml").string());
    result.ok = code == 0;
    if (code != 0) result.error = "swarmloc run exited with " + std::to_string(code);
    if (code == 3) {
      // Degraded: complete, but not representative of the configured system; left out of the cell.
      result.error = "degraded (exit 3):";
      for (const auto& reason : summary["health"].value("reasons", nlohmann::json::array()))
        result.error += " " + reason.get<std::string>() + ";";
    }
    const std::string error = result.error;
    measure(result, summary, read_metrics_csv(result.run_dir / "metrics.csv"), scenario.run.rate_hz);
    if (!error.empty()) result.ok = false, result.error = error;
  } catch (const std::exception& error) {
    result.ok = false;
    result.error = "exit " + std::to_string(code) + "; no readable run directory (" + error.what() + ")";
  }
}

}  // namespace campaign_detail

std::int64_t converge_step(const std::vector<RmseSample>& steps) {
  if (steps.empty() || steps.back().missing != 0) return -1;
  const double final_rmse = steps.back().rmse_m;
  double first_rmse = final_rmse;
  for (const auto& step : steps) {
    if (step.missing == 0) {
      first_rmse = step.rmse_m;
      break;
    }
  }
  const double band = std::max(1.1 * final_rmse, final_rmse + 0.1 * (first_rmse - final_rmse));
  std::int64_t converged = static_cast<std::int64_t>(steps.size()) - 1;
  for (auto k = converged; k >= 0; --k) {
    const auto& step = steps[static_cast<std::size_t>(k)];
    if (step.missing != 0 || !(step.rmse_m <= band)) break;
    converged = k;
  }
  return converged;
}

bool still_falling(const std::vector<RmseSample>& steps) {
  const std::size_t n = steps.size();
  if (n < 20) return false;
  auto mean_rmse = [&](std::size_t begin, std::size_t end) {
    double sum = 0.0;
    int count = 0;
    for (std::size_t k = begin; k < end; ++k) {
      if (steps[k].missing != 0) continue;
      sum += steps[k].rmse_m;
      ++count;
    }
    return count > 0 ? sum / count : campaign_detail::kNaN;
  };
  const double earlier = mean_rmse(7 * n / 10, 8 * n / 10);
  const double last = mean_rmse(9 * n / 10, n);
  return std::isfinite(earlier) && std::isfinite(last) && last < 0.8 * earlier;
}

}  // namespace swarmloc::research
