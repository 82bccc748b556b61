#include "campaign.hpp"

#include <fcntl.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>

#include "orchestrator.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/rundir/output_file.hpp"
#include "swarmloc/rundir/plots.hpp"
#include "swarmloc/sim/simulator.hpp"

namespace swarmloc::orchestrator {
namespace {

using Clock = std::chrono::steady_clock;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// ---------------- spec parsing ----------------

/// Every error names the spec file and the key path inside it (exit code 2, like a bad scenario).
class SpecReader {
 public:
  explicit SpecReader(std::string origin) : origin_(std::move(origin)) {}

  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    throw config::ScenarioError("campaign spec " + origin_ + ": " + key + ": " + what);
  }

  void require_keys(const YAML::Node& map, const std::string& path,
                    const std::set<std::string>& allowed) const {
    if (!map.IsMap()) fail(path.empty() ? "(top level)" : path, "must be a map");
    for (const auto& entry : map) {
      const auto key = entry.first.as<std::string>();
      if (allowed.count(key) == 0) {
        std::string list;
        for (const auto& name : allowed) list += (list.empty() ? "" : ", ") + name;
        fail(join(path, key), "unknown key (expected one of: " + list + ")");
      }
    }
  }

  std::string scalar(const YAML::Node& node, const std::string& path) const {
    if (!node.IsScalar() || node.Scalar().empty()) fail(path, "must be a non-empty scalar");
    return node.Scalar();
  }

  /// A map of scenario keys to scalar values, as "key=value" overrides (key checked against the
  /// scenario's key list so a typo is named here rather than deep inside a cell).
  std::vector<std::string> overrides(const YAML::Node& node, const std::string& path) const {
    std::vector<std::string> out;
    if (!node || node.IsNull()) return out;
    if (!node.IsMap()) fail(path, "must be a map of scenario keys to values, e.g. {run.steps: 100}");
    const auto& known = config::known_keys();
    for (const auto& entry : node) {
      const auto key = entry.first.as<std::string>();
      if (std::find(known.begin(), known.end(), key) == known.end()) {
        fail(join(path, key), "unknown scenario key (see docs/scenario.md or `swarmloc run --help`)");
      }
      out.push_back(key + "=" + scalar(entry.second, join(path, key)));
    }
    return out;
  }

  std::vector<std::uint64_t> seeds(const YAML::Node& node, const std::string& path) const {
    std::vector<std::uint64_t> out;
    try {
      if (node.IsScalar()) {
        const int count = node.as<int>();
        if (count < 1 || count > 1000) fail(path, "a seed count must be in [1, 1000]");
        for (int k = 1; k <= count; ++k) out.push_back(static_cast<std::uint64_t>(k));
      } else if (node.IsSequence() && node.size() > 0) {
        for (const auto& seed : node) out.push_back(seed.as<std::uint64_t>());
      } else {
        fail(path, "must be a seed count or a non-empty list of seeds");
      }
    } catch (const YAML::BadConversion&) {
      fail(path, "must be a seed count or a non-empty list of non-negative integers");
    }
    return out;
  }

  static std::string join(const std::string& path, const std::string& key) {
    return path.empty() ? key : path + "." + key;
  }

 private:
  std::string origin_;
};

std::vector<std::string> parse_modes(const std::string& mode, const SpecReader& reader,
                                     const std::string& path) {
  if (mode == "sim") return {"sim"};
  if (mode == "dds") return {"dds"};
  if (mode == "both") return {"sim", "dds"};
  reader.fail(path, "'" + mode + "' is not one of sim, dds, both");
}

/// Overrides of one cell, in the order they apply (later wins).
std::vector<std::string> cell_overrides(const CampaignSpec& spec, std::size_t algorithm, std::size_t variant,
                                        std::size_t value, std::uint64_t seed) {
  std::vector<std::string> out = spec.overrides;
  const auto& a = spec.algorithms[algorithm].overrides;
  const auto& v = spec.variants[variant].overrides;
  out.insert(out.end(), a.begin(), a.end());
  out.insert(out.end(), v.begin(), v.end());
  out.push_back(spec.swept_key + "=" + spec.swept_values[value]);
  out.push_back("seed=" + std::to_string(seed));
  return out;
}

std::string cell_name(const CampaignSpec& spec, std::size_t algorithm, std::size_t variant,
                      std::size_t value) {
  return spec.algorithms[algorithm].label + " / " + spec.variants[variant].label + " / " + spec.swept_key +
         "=" + spec.swept_values[value];
}

/// A label as a directory name.
std::string path_safe(const std::string& text) {
  std::string out;
  for (char c : text) out += (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-') ? c : '_';
  return out;
}

// ---------------- one run ----------------

struct RunResult {
  std::string mode;
  std::size_t algorithm = 0, variant = 0, value = 0;
  std::uint64_t seed = 0;
  bool ok = false;
  std::string error;
  double final_rmse_m = kNaN;
  double crlb_rmse_m = kNaN;  ///< static all-draws CRLB at the last step (summary.json "crlb", older readers)
  double bound_rmse_m = kNaN;  ///< the run's bound at the last step (summary.json "bound"; NaN: none)
  std::string bound_kind;      ///< crlb_static_accumulated, pcrb or none (docs/algorithms.md §1.3.1)
  std::int64_t converge_step = -1;
  double converge_s = kNaN;
  bool still_falling = false;
  std::uint64_t sent = 0, delivered = 0, dropped_injected = 0;
  double wall_s = 0.0;
  std::filesystem::path run_dir;
};

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

void write_metrics_csv(const std::filesystem::path& path, const sim::RunRecord& record) {
  std::ostringstream out;
  out << "step,time_s,rmse_m,mean_error_m,max_error_m,crlb_rmse_m,nees,scored,missing\n"
      << std::setprecision(9);
  for (const auto& m : record.metrics) {
    out << m.step << ',' << m.time_s << ',' << m.errors.rmse_m << ',' << m.errors.mean_error_m << ','
        << m.errors.max_error_m << ',' << m.crlb_rmse_m << ',' << m.errors.nees << ',' << m.errors.scored
        << ',' << m.errors.missing << '\n';
  }
  sim::write_text_file(path, out.str());
}

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
    sim::create_output_directories(result.run_dir);
    sim::write_text_file(result.run_dir / "scenario.yaml", config::to_yaml(scenario));
    const auto summary = sim::summary_json(record);
    write_metrics_csv(result.run_dir / "metrics.csv", record);
    // Last and atomic, as in a full run directory: its presence means the cell's files are complete.
    sim::write_text_file_atomic(result.run_dir / "summary.json", summary.dump(2) + "\n");
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

/// A DDS cell: the same code path as `swarmloc run` (orchestrator in this process, one agent process
/// per agent), then its run directory is read back.
void run_dds_cell(const CampaignSpec& spec, RunResult& result, const std::string& agent_binary,
                  bool& interrupted) {
  const auto started = Clock::now();
  RunOptions options;
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
    code = run_orchestrator(options);
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

// ---------------- aggregation and output ----------------

struct CellStats {
  int runs = 0;  ///< successful seeds
  int failed = 0;
  double rmse_mean = kNaN, rmse_std = kNaN, bound_mean = kNaN, converge_s_mean = kNaN;
  double delivered_fraction = kNaN;
  double ratio = kNaN;  ///< rmse_mean / the reference (first swept value) cell's rmse_mean
  /// Median over seeds of (this seed's RMSE / the same seed's reference RMSE): one badly placed world
  /// (a seed where the algorithm is poor even without loss) cannot dominate it.
  double seed_ratio_median = kNaN;
  std::vector<std::uint64_t> still_falling_seeds;  ///< runs whose RMSE was still falling at the horizon
};

double median_of(std::vector<double> values) {
  if (values.empty()) return kNaN;
  std::sort(values.begin(), values.end());
  const auto middle = values.size() / 2;
  return values.size() % 2 == 1 ? values[middle] : 0.5 * (values[middle - 1] + values[middle]);
}

double mean_of(const std::vector<double>& values) {
  if (values.empty()) return kNaN;
  double sum = 0.0;
  for (double v : values) sum += v;
  return sum / static_cast<double>(values.size());
}

/// Sample standard deviation (0 for a single value).
double std_of(const std::vector<double>& values) {
  if (values.size() < 2) return values.empty() ? kNaN : 0.0;
  const double mean = mean_of(values);
  double sq = 0.0;
  for (double v : values) sq += (v - mean) * (v - mean);
  return std::sqrt(sq / static_cast<double>(values.size() - 1));
}

using CellKey =
    std::tuple<std::string, std::size_t, std::size_t, std::size_t>;  // mode, algorithm, variant, value

std::map<CellKey, CellStats> aggregate(const std::vector<RunResult>& runs) {
  std::map<CellKey, std::vector<const RunResult*>> grouped;
  std::map<std::tuple<std::string, std::size_t, std::size_t, std::uint64_t>, double> reference;  // per seed
  for (const auto& run : runs) {
    grouped[{run.mode, run.algorithm, run.variant, run.value}].push_back(&run);
    if (run.value == 0 && run.ok)
      reference[{run.mode, run.algorithm, run.variant, run.seed}] = run.final_rmse_m;
  }
  std::map<CellKey, CellStats> cells;
  for (const auto& [key, members] : grouped) {
    CellStats stats;
    std::vector<double> rmse, bound, converge, seed_ratios;
    std::uint64_t sent = 0, delivered = 0;
    for (const auto* run : members) {
      if (!run->ok) {
        ++stats.failed;
        continue;
      }
      ++stats.runs;
      rmse.push_back(run->final_rmse_m);
      const auto ref = reference.find({run->mode, run->algorithm, run->variant, run->seed});
      if (ref != reference.end()) seed_ratios.push_back(run->final_rmse_m / ref->second);
      if (std::isfinite(run->bound_rmse_m)) bound.push_back(run->bound_rmse_m);
      if (std::isfinite(run->converge_s)) converge.push_back(run->converge_s);
      if (run->still_falling) stats.still_falling_seeds.push_back(run->seed);
      sent += run->sent;
      delivered += run->delivered;
    }
    stats.rmse_mean = mean_of(rmse);
    stats.rmse_std = std_of(rmse);
    stats.seed_ratio_median = median_of(seed_ratios);
    stats.bound_mean = mean_of(bound);
    stats.converge_s_mean = mean_of(converge);
    stats.delivered_fraction = sent > 0 ? static_cast<double>(delivered) / static_cast<double>(sent) : kNaN;
    cells[key] = stats;
  }
  for (auto& [key, stats] : cells) {
    const auto& [mode, algorithm, variant, value] = key;
    const auto reference_cell = cells.find({mode, algorithm, variant, 0});
    if (reference_cell != cells.end()) stats.ratio = stats.rmse_mean / reference_cell->second.rmse_mean;
  }
  return cells;
}

std::string fmt(const char* format, double value) {
  if (!std::isfinite(value)) return "n/a";
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, value);
  return buffer;
}

std::string header_row(const CampaignSpec& spec, std::string& rule) {
  std::string row = "| " + spec.swept_key + " |";
  rule = "|---|";
  for (const auto& algorithm : spec.algorithms) {
    for (const auto& variant : spec.variants) {
      row += " " + algorithm.label + (spec.variants.size() > 1 ? " " + variant.label : "") + " |";
      rule += "---|";
    }
  }
  return row;
}

template <typename CellText>
void table(std::ostringstream& md, const CampaignSpec& spec, const std::string& mode,
           const std::map<CellKey, CellStats>& cells, CellText&& text) {
  std::string rule;
  md << header_row(spec, rule) << "\n" << rule << "\n";
  for (std::size_t value = 0; value < spec.swept_values.size(); ++value) {
    md << "| " << spec.swept_values[value] << " |";
    for (std::size_t a = 0; a < spec.algorithms.size(); ++a) {
      for (std::size_t v = 0; v < spec.variants.size(); ++v) {
        const auto found = cells.find({mode, a, v, value});
        md << " " << (found == cells.end() ? std::string("—") : text(found->second)) << " |";
      }
    }
    md << "\n";
  }
  md << "\n";
}

struct ModeRun {
  std::string mode;
  std::size_t seeds = 0;
  double wall_s = 0.0;
  bool interrupted = false;
};

std::string campaign_markdown(const CampaignSpec& spec, const std::vector<ModeRun>& modes,
                              const std::map<CellKey, CellStats>& cells) {
  std::ostringstream md;
  md << "# Campaign `" << spec.name << "`: " << spec.swept_key << " swept over";
  for (const auto& value : spec.swept_values) md << " " << value;
  md << "\n\nThe reference of every ratio is the same algorithm and variant at " << spec.swept_key << " = "
     << spec.swept_values.front()
     << ". Time to converge: the first step from which the RMSE stays at or below max(1.1 · final, final + "
        "0.1 · (first − final)), in world seconds, mean over seeds. Delivered: inter-agent samples "
        "delivered / sent (all seeds).\n\n";
  for (const auto& run : modes) {
    const auto& mode = run.mode;
    md << "## " << (mode == "sim" ? "Simulator" : "DDS (one OS process per agent)") << " — " << run.seeds
       << " seed" << (run.seeds == 1 ? "" : "s") << " per cell, wall " << fmt("%.0f", run.wall_s) << " s"
       << (run.interrupted ? " (interrupted)" : "") << "\n\n";
    md << "Final RMSE ÷ reference: ratio of the means over seeds [median over seeds of the per-seed ratio], "
          "with the final RMSE in metres (mean ± std over seeds):\n\n";
    table(md, spec, mode, cells, [](const CellStats& c) {
      if (c.runs == 0) return std::string("failed");
      return fmt("%.2f", c.ratio) + " [" + fmt("%.2f", c.seed_ratio_median) + "] (" +
             fmt("%.3g", c.rmse_mean) + " ± " + fmt("%.2g", c.rmse_std) + ")" +
             (c.failed > 0 ? " " + std::to_string(c.failed) + " failed" : "");
    });
    md << "Final RMSE / the run's bound (summary.json `bound`: the accumulated CRLB or posterior CRB of the "
          "algorithm's data; n/a: no bound):\n\n";
    table(md, spec, mode, cells, [](const CellStats& c) { return fmt("%.2f", c.rmse_mean / c.bound_mean); });
    md << "Time to converge (s):\n\n";
    table(md, spec, mode, cells, [](const CellStats& c) { return fmt("%.1f", c.converge_s_mean); });
    md << "Delivered fraction of inter-agent samples:\n\n";
    table(md, spec, mode, cells, [](const CellStats& c) { return fmt("%.3f", c.delivered_fraction); });
    if (spec.check_value) {
      const auto at = std::find(spec.swept_values.begin(), spec.swept_values.end(), *spec.check_value);
      const auto index = static_cast<std::size_t>(at - spec.swept_values.begin());
      md << "Check: final RMSE at " << spec.swept_key << " = " << *spec.check_value << " ≤ "
         << fmt("%g", spec.check_max_ratio)
         << " × reference (the ratio of means decides; [median per-seed ratio]):";
      for (std::size_t a = 0; a < spec.algorithms.size(); ++a) {
        for (std::size_t v = 0; v < spec.variants.size(); ++v) {
          const auto found = cells.find({mode, a, v, index});
          const double ratio = found == cells.end() ? kNaN : found->second.ratio;
          const double median = found == cells.end() ? kNaN : found->second.seed_ratio_median;
          md << " " << spec.algorithms[a].label
             << (spec.variants.size() > 1 ? " " + spec.variants[v].label : "") << " " << fmt("%.2f", ratio)
             << " [" << fmt("%.2f", median) << "]"
             << (std::isfinite(ratio) && ratio <= spec.check_max_ratio ? " pass" : " FAIL") << ";";
        }
      }
      md << "\n\n";
    }
    std::string unsettled;  // references still falling at the horizon: their ratios compare transients
    for (std::size_t a = 0; a < spec.algorithms.size(); ++a) {
      for (std::size_t v = 0; v < spec.variants.size(); ++v) {
        const auto found = cells.find({mode, a, v, 0});
        if (found == cells.end() || found->second.still_falling_seeds.empty()) continue;
        unsettled += " " + spec.algorithms[a].label +
                     (spec.variants.size() > 1 ? " " + spec.variants[v].label : "") + " (seed";
        for (const auto seed : found->second.still_falling_seeds) unsettled += " " + std::to_string(seed);
        unsettled += ");";
      }
    }
    md << "Reference runs (" << spec.swept_key << " = " << spec.swept_values.front()
       << ") still falling at the horizon (RMSE over the last 10 % of steps < 0.8 × over 70–80 %):"
       << (unsettled.empty() ? " none." : unsettled + " their ratios compare transients: lengthen run.steps.")
       << "\n\n";
  }
  md << "Plot: campaign.png (final RMSE ratio and time to converge vs " << spec.swept_key
     << "). Per-run rows: campaign.csv.\n";
  return md.str();
}

void write_csv(const std::filesystem::path& path, const CampaignSpec& spec,
               const std::vector<RunResult>& runs) {
  // Per-seed ratio: this run's final RMSE over the same seed's reference-cell run.
  std::map<std::tuple<std::string, std::size_t, std::size_t, std::uint64_t>, double> reference;
  for (const auto& run : runs) {
    if (run.value == 0 && run.ok)
      reference[{run.mode, run.algorithm, run.variant, run.seed}] = run.final_rmse_m;
  }
  std::ostringstream out;
  out << "mode,algorithm,variant,swept_key,swept_value,seed,ok,final_rmse_m,crlb_rmse_m,rmse_over_crlb,"
         "ratio_to_reference,converge_step,converge_s,still_falling,sent,delivered,dropped_injected,"
         "delivered_fraction,"
         "wall_s,bound_kind,bound_rmse_m,rmse_over_bound,"
         "run_dir,error\n"
      << std::setprecision(9);
  auto number = [](double v) {
    return std::isfinite(v) ? (std::ostringstream() << std::setprecision(9) << v).str() : "";
  };
  for (const auto& run : runs) {
    const auto ref = reference.find({run.mode, run.algorithm, run.variant, run.seed});
    const double ratio = ref == reference.end() ? kNaN : run.final_rmse_m / ref->second;
    std::string error = run.error;
    std::replace(error.begin(), error.end(), ',', ';');
    std::replace(error.begin(), error.end(), '\n', ' ');
    out << run.mode << ',' << spec.algorithms[run.algorithm].label << ',' << spec.variants[run.variant].label
        << ',' << spec.swept_key << ',' << spec.swept_values[run.value] << ',' << run.seed << ','
        << (run.ok ? 1 : 0) << ',' << number(run.final_rmse_m) << ',' << number(run.crlb_rmse_m) << ','
        << number(run.final_rmse_m / run.crlb_rmse_m) << ',' << number(ratio) << ',' << run.converge_step
        << ',' << number(run.converge_s) << ',' << (run.still_falling ? 1 : 0) << ',' << run.sent << ','
        << run.delivered << ',' << run.dropped_injected << ','
        << number(run.sent > 0 ? static_cast<double>(run.delivered) / static_cast<double>(run.sent) : kNaN)
        << ',' << number(run.wall_s) << ',' << run.bound_kind << ',' << number(run.bound_rmse_m) << ','
        << number(run.final_rmse_m / run.bound_rmse_m) << ',' << run.run_dir.string() << ',' << error << '\n';
  }
  sim::write_text_file(path, out.str());
}

/// A data file's quoted column cannot hold a double quote.
std::string without_double_quotes(std::string text) {
  std::replace(text.begin(), text.end(), '"', '\'');
  return text;
}

/// campaign.gp + campaign_plot.dat (always) and campaign.png (when gnuplot is installed): per mode one
/// row of two panels, final RMSE ÷ reference and time to converge vs the swept value; a line per
/// algorithm × variant (colour = algorithm, dash = variant).
void write_plot(const std::filesystem::path& directory, const CampaignSpec& spec,
                const std::vector<ModeRun>& modes, const std::map<CellKey, CellStats>& cells) {
  bool numeric = true;
  std::vector<double> xs;
  for (const auto& value : spec.swept_values) {
    char* end = nullptr;
    const double x = std::strtod(value.c_str(), &end);
    numeric = numeric && end != value.c_str() && *end == '\0';
    xs.push_back(x);
  }
  if (!numeric) {
    for (std::size_t k = 0; k < xs.size(); ++k) xs[k] = static_cast<double>(k);
  }
  std::ostringstream data;
  data << std::setprecision(9);
  std::ostringstream gp;
  gp << "# Made by `swarmloc campaign`; run `gnuplot campaign.gp` in this directory to redraw.\n"
     << "set terminal pngcairo size 1400," << 450 * std::max<std::size_t>(1, modes.size()) << " font ',10'\n"
     << "set output 'campaign.png'\nset grid\nset key outside right top\n"
     << "set multiplot layout " << modes.size() << ",2\n";
  int block = 0;
  for (const auto& run : modes) {
    std::vector<std::pair<int, std::string>> series;  // data block, title
    std::vector<std::pair<std::size_t, std::size_t>> style;
    for (std::size_t a = 0; a < spec.algorithms.size(); ++a) {
      for (std::size_t v = 0; v < spec.variants.size(); ++v) {
        data << "# " << run.mode << " " << spec.algorithms[a].label << " " << spec.variants[v].label << "\n";
        for (std::size_t value = 0; value < spec.swept_values.size(); ++value) {
          const auto found = cells.find({run.mode, a, v, value});
          if (found == cells.end()) continue;
          auto cell = [](double y) { return std::isfinite(y) ? std::to_string(y) : std::string("NaN"); };
          data << xs[value] << ' ' << cell(found->second.ratio) << ' ' << cell(found->second.converge_s_mean)
               << " \"" << without_double_quotes(spec.swept_values[value]) << "\"\n";
        }
        data << "\n\n";
        series.emplace_back(block++, spec.algorithms[a].label +
                                         (spec.variants.size() > 1 ? " " + spec.variants[v].label : ""));
        style.emplace_back(a, v);
      }
    }
    const std::string where = run.mode == "sim" ? "simulator" : "DDS";
    const std::string xtics = numeric ? "" : ":xtic(4)";
    for (int panel = 0; panel < 2; ++panel) {
      // Log scale for the ratio: one run in a wrong local minimum (×30) must not flatten every other line.
      gp << (panel == 0 ? "set logscale y\n" : "unset logscale y\n");
      // Labels come from the spec: quoted for gnuplot, never pasted into a command.
      gp << "set title "
         << sim::gnuplot_quote((panel == 0 ? "final RMSE ÷ reference (" : "time to converge, s (") + where +
                               ")")
         << "\n"
         << "set xlabel " << sim::gnuplot_quote(spec.swept_key) << "\n"
         << "set ylabel "
         << sim::gnuplot_quote(panel == 0 ? "RMSE ÷ RMSE at " + spec.swept_values.front() : "s") << "\n"
         << "plot ";
      for (std::size_t s = 0; s < series.size(); ++s) {
        gp << (s ? ", \\\n     " : "") << "'campaign_plot.dat' index " << series[s].first
           << " using 1:" << (panel == 0 ? 2 : 3) << xtics << " with linespoints lc " << style[s].first + 1
           << " dt " << style[s].second + 1 << " pt " << style[s].first + 4 << " title "
           << sim::gnuplot_quote(series[s].second);
      }
      if (panel == 0 && spec.check_value) {
        gp << ", \\\n     " << spec.check_max_ratio << " with lines lc rgb 'gray' dt 3 title '"
           << spec.check_max_ratio << "×'";
      }
      gp << "\n";
    }
  }
  gp << "unset multiplot\n";
  sim::write_text_file(directory / "campaign_plot.dat", data.str());
  sim::write_text_file(directory / "campaign.gp", gp.str());
  sim::run_gnuplot(directory, "campaign.gp", {"campaign.png"});
}

std::filesystem::path default_campaign_directory(const CampaignSpec& spec) {
  const auto now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm utc{};
  gmtime_r(&now, &utc);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", &utc);
  return std::filesystem::path("runs") / ("campaign-" + path_safe(spec.name) + "-" + stamp);
}

std::string progress_line(const CampaignSpec& spec, const RunResult& run, std::size_t done, std::size_t total,
                          double elapsed_s) {
  char line[400];
  if (!run.ok) {
    std::snprintf(line, sizeof line, "[%6.0fs] %zu/%zu %s %s seed %llu: FAILED (%s)", elapsed_s, done, total,
                  run.mode.c_str(), cell_name(spec, run.algorithm, run.variant, run.value).c_str(),
                  static_cast<unsigned long long>(run.seed), run.error.c_str());
  } else {
    std::snprintf(line, sizeof line,
                  "[%6.0fs] %zu/%zu %s %s seed %llu: RMSE %.4g m, converged at %s s (%.1f s)", elapsed_s,
                  done, total, run.mode.c_str(),
                  cell_name(spec, run.algorithm, run.variant, run.value).c_str(),
                  static_cast<unsigned long long>(run.seed), run.final_rmse_m,
                  fmt("%.1f", run.converge_s).c_str(), run.wall_s);
  }
  return line;
}

}  // namespace

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
    return count > 0 ? sum / count : kNaN;
  };
  const double earlier = mean_rmse(7 * n / 10, 8 * n / 10);
  const double last = mean_rmse(9 * n / 10, n);
  return std::isfinite(earlier) && std::isfinite(last) && last < 0.8 * earlier;
}

CampaignSpec load_campaign_spec(const std::filesystem::path& path) {
  const SpecReader reader(path.string());
  YAML::Node root;
  try {
    root = YAML::LoadFile(path.string());
  } catch (const YAML::BadFile&) {
    throw config::ScenarioError("campaign spec " + path.string() + ": cannot read the file");
  } catch (const YAML::Exception& error) {
    throw config::ScenarioError("campaign spec " + path.string() + ": YAML error: " + error.what());
  }
  reader.require_keys(root, "",
                      {"name", "mode", "seeds", "dds_seeds", "threads", "overrides", "algorithms", "sweep",
                       "variants", "check"});
  CampaignSpec spec;
  const auto base = path.parent_path();
  if (root["name"]) spec.name = reader.scalar(root["name"], "name");
  if (root["mode"]) spec.modes = parse_modes(reader.scalar(root["mode"], "mode"), reader, "mode");
  if (root["seeds"]) spec.seeds = reader.seeds(root["seeds"], "seeds");
  if (root["dds_seeds"]) spec.dds_seeds = reader.seeds(root["dds_seeds"], "dds_seeds");
  if (root["threads"]) {
    try {
      spec.threads = root["threads"].as<int>();
    } catch (const YAML::BadConversion&) {
      reader.fail("threads", "must be an integer");
    }
    if (spec.threads < 0 || spec.threads > 1024)
      reader.fail("threads", "must be in [0, 1024] (0 = every core)");
  }
  spec.overrides = reader.overrides(root["overrides"], "overrides");

  const auto algorithms = root["algorithms"];
  if (!algorithms || !algorithms.IsSequence() || algorithms.size() == 0) {
    reader.fail("algorithms", "must be a non-empty list of {label, scenario, overrides}");
  }
  for (std::size_t k = 0; k < algorithms.size(); ++k) {
    const std::string where = "algorithms[" + std::to_string(k) + "]";
    const auto node = algorithms[k];
    reader.require_keys(node, where, {"label", "scenario", "overrides"});
    if (!node["label"]) reader.fail(where + ".label", "is required");
    if (!node["scenario"]) reader.fail(where + ".scenario", "is required");
    CampaignSpec::Algorithm algorithm;
    algorithm.label = reader.scalar(node["label"], where + ".label");
    algorithm.scenario = reader.scalar(node["scenario"], where + ".scenario");
    if (algorithm.scenario.is_relative()) algorithm.scenario = (base / algorithm.scenario).lexically_normal();
    if (!std::filesystem::exists(algorithm.scenario)) {
      reader.fail(where + ".scenario", "no such file: " + algorithm.scenario.string());
    }
    algorithm.overrides = reader.overrides(node["overrides"], where + ".overrides");
    for (const auto& other : spec.algorithms) {
      if (other.label == algorithm.label)
        reader.fail(where + ".label", "'" + algorithm.label + "' is used twice");
    }
    spec.algorithms.push_back(algorithm);
  }

  const auto sweep = root["sweep"];
  if (!sweep) reader.fail("sweep", "is required: {key: SCENARIO.KEY, values: [ ... ]}");
  reader.require_keys(sweep, "sweep", {"key", "values"});
  if (!sweep["key"]) reader.fail("sweep.key", "is required");
  spec.swept_key = reader.scalar(sweep["key"], "sweep.key");
  const auto& known = config::known_keys();
  if (std::find(known.begin(), known.end(), spec.swept_key) == known.end() || spec.swept_key == "seed") {
    reader.fail("sweep.key",
                "'" + spec.swept_key + "' is not a scenario key that can be swept (see docs/scenario.md)");
  }
  const auto values = sweep["values"];
  if (!values || !values.IsSequence() || values.size() == 0)
    reader.fail("sweep.values", "must be a non-empty list");
  for (std::size_t k = 0; k < values.size(); ++k) {
    spec.swept_values.push_back(reader.scalar(values[k], "sweep.values[" + std::to_string(k) + "]"));
  }

  if (const auto variants = root["variants"]) {
    if (!variants.IsSequence() || variants.size() == 0) {
      reader.fail("variants", "must be a non-empty list of {label, overrides}");
    }
    for (std::size_t k = 0; k < variants.size(); ++k) {
      const std::string where = "variants[" + std::to_string(k) + "]";
      reader.require_keys(variants[k], where, {"label", "overrides"});
      if (!variants[k]["label"]) reader.fail(where + ".label", "is required");
      CampaignSpec::Variant variant{reader.scalar(variants[k]["label"], where + ".label"),
                                    reader.overrides(variants[k]["overrides"], where + ".overrides")};
      for (const auto& other : spec.variants) {
        if (other.label == variant.label)
          reader.fail(where + ".label", "'" + variant.label + "' is used twice");
      }
      spec.variants.push_back(variant);
    }
  } else {
    spec.variants.push_back({"-", {}});
  }

  if (const auto check = root["check"]) {
    reader.require_keys(check, "check", {"value", "max_ratio"});
    if (!check["value"]) reader.fail("check.value", "is required");
    spec.check_value = reader.scalar(check["value"], "check.value");
    if (std::find(spec.swept_values.begin(), spec.swept_values.end(), *spec.check_value) ==
        spec.swept_values.end()) {
      reader.fail("check.value", "'" + *spec.check_value + "' is not one of sweep.values");
    }
    if (check["max_ratio"]) {
      try {
        spec.check_max_ratio = check["max_ratio"].as<double>();
      } catch (const YAML::BadConversion&) {
        reader.fail("check.max_ratio", "must be a number");
      }
      if (!(spec.check_max_ratio > 0.0)) reader.fail("check.max_ratio", "must be > 0");
    }
  }

  // Every cell's scenario must load (the scenario loader names the offending key and value).
  for (std::size_t a = 0; a < spec.algorithms.size(); ++a) {
    for (std::size_t v = 0; v < spec.variants.size(); ++v) {
      for (std::size_t value = 0; value < spec.swept_values.size(); ++value) {
        try {
          (void)config::load_scenario(spec.algorithms[a].scenario.string(),
                                      cell_overrides(spec, a, v, value, spec.seeds.front()));
        } catch (const config::ScenarioError& error) {
          throw config::ScenarioError("campaign spec " + path.string() + ", cell " +
                                      cell_name(spec, a, v, value) + ": " + error.what());
        }
      }
    }
  }
  return spec;
}

std::string campaign_spec_yaml(const CampaignSpec& spec) {
  YAML::Emitter out;
  auto overrides_map = [&](const std::vector<std::string>& overrides) {
    out << YAML::BeginMap;
    for (const auto& o : overrides) {
      const auto eq = o.find('=');
      out << YAML::Key << o.substr(0, eq) << YAML::Value << o.substr(eq + 1);
    }
    out << YAML::EndMap;
  };
  out << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << spec.name;
  out << YAML::Key << "mode" << YAML::Value << (spec.modes.size() == 2 ? "both" : spec.modes.front());
  out << YAML::Key << "seeds" << YAML::Value << YAML::Flow << spec.seeds;
  if (!spec.dds_seeds.empty()) out << YAML::Key << "dds_seeds" << YAML::Value << YAML::Flow << spec.dds_seeds;
  out << YAML::Key << "threads" << YAML::Value << spec.threads;
  out << YAML::Key << "overrides" << YAML::Value;
  overrides_map(spec.overrides);
  out << YAML::Key << "algorithms" << YAML::Value << YAML::BeginSeq;
  for (const auto& a : spec.algorithms) {
    out << YAML::BeginMap << YAML::Key << "label" << YAML::Value << a.label << YAML::Key << "scenario"
        << YAML::Value << std::filesystem::absolute(a.scenario).lexically_normal().string() << YAML::Key
        << "overrides" << YAML::Value;
    overrides_map(a.overrides);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::Key << "sweep" << YAML::Value << YAML::BeginMap << YAML::Key << "key" << YAML::Value
      << spec.swept_key << YAML::Key << "values" << YAML::Value << YAML::Flow << spec.swept_values
      << YAML::EndMap;
  out << YAML::Key << "variants" << YAML::Value << YAML::BeginSeq;
  for (const auto& v : spec.variants) {
    out << YAML::BeginMap << YAML::Key << "label" << YAML::Value << v.label << YAML::Key << "overrides"
        << YAML::Value;
    overrides_map(v.overrides);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  if (spec.check_value) {
    out << YAML::Key << "check" << YAML::Value << YAML::BeginMap << YAML::Key << "value" << YAML::Value
        << *spec.check_value << YAML::Key << "max_ratio" << YAML::Value << spec.check_max_ratio
        << YAML::EndMap;
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

int run_campaign(const CampaignOptions& options) {
  CampaignSpec spec;
  try {
    spec = load_campaign_spec(options.spec_path);
    if (!options.mode.empty()) {
      spec.modes = parse_modes(options.mode, SpecReader("--mode"), "--mode");
    }
    if (options.seeds > 0) {
      spec.seeds.clear();
      for (int k = 1; k <= options.seeds; ++k) spec.seeds.push_back(static_cast<std::uint64_t>(k));
      spec.dds_seeds.clear();
    }
  } catch (const config::ScenarioError& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 2;
  }
  const auto out_dir = options.out_dir.empty() ? default_campaign_directory(spec) : options.out_dir;
  try {
    sim::create_output_directories(out_dir);
    sim::write_text_file(out_dir / "spec.yaml", "# The campaign as run (swarmloc campaign " +
                                                    options.spec_path.string() + ")\n" +
                                                    campaign_spec_yaml(spec));
  } catch (const sim::OutputError& error) {
    std::fprintf(stderr, "error: --out: %s\n", error.what());
    return 2;
  }

  std::vector<RunResult> runs;
  std::vector<ModeRun> mode_runs;
  bool failed = false;
  const auto campaign_started = Clock::now();
  for (const auto& mode : spec.modes) {
    const auto& seeds = mode == "dds" && !spec.dds_seeds.empty() ? spec.dds_seeds : spec.seeds;
    std::vector<RunResult> jobs;
    for (std::size_t a = 0; a < spec.algorithms.size(); ++a) {
      for (std::size_t v = 0; v < spec.variants.size(); ++v) {
        for (std::size_t value = 0; value < spec.swept_values.size(); ++value) {
          for (const auto seed : seeds) {
            RunResult job;
            job.mode = mode;
            job.algorithm = a, job.variant = v, job.value = value, job.seed = seed;
            job.run_dir =
                out_dir / mode / path_safe(spec.algorithms[a].label) / path_safe(spec.variants[v].label) /
                path_safe(spec.swept_key + "=" + spec.swept_values[value]) / ("seed" + std::to_string(seed));
            jobs.push_back(job);
          }
        }
      }
    }
    if (options.progress) {
      std::fprintf(stderr,
                   "campaign %s: %s, %zu runs (%zu algorithms × %zu variants × %zu values × %zu seeds)\n",
                   spec.name.c_str(), mode.c_str(), jobs.size(), spec.algorithms.size(), spec.variants.size(),
                   spec.swept_values.size(), seeds.size());
    }
    ModeRun mode_run{mode, seeds.size(), 0.0, false};
    const auto started = Clock::now();
    std::mutex report_mutex;
    std::size_t done = 0;
    auto report = [&](const RunResult& run) {
      const std::lock_guard lock(report_mutex);
      ++done;
      if (options.progress || !run.ok) {
        std::fprintf(stderr, "%s\n",
                     progress_line(spec, run, done, jobs.size(), seconds_since(started)).c_str());
      }
    };
    if (mode == "sim") {
      // Cells are independent and deterministic in their seed: run them on every core.
      const int threads = spec.threads > 0
                              ? spec.threads
                              : static_cast<int>(std::max(1U, std::thread::hardware_concurrency()));
      std::atomic<std::size_t> next{0};
      std::vector<std::thread> pool;
      for (int t = 0; t < threads; ++t) {
        pool.emplace_back([&] {
          for (auto k = next++; k < jobs.size(); k = next++) {
            run_sim_cell(spec, jobs[k]);
            report(jobs[k]);
          }
        });
      }
      for (auto& thread : pool) thread.join();
    } else {
      // One at a time: each run already puts one process per agent on the machine.
      for (auto& job : jobs) {
        bool interrupted = false;
        run_dds_cell(spec, job, options.agent_binary, interrupted);
        report(job);
        if (interrupted) {
          mode_run.interrupted = true;
          std::fprintf(stderr, "campaign interrupted; writing what ran\n");
          break;
        }
      }
    }
    mode_run.wall_s = seconds_since(started);
    for (const auto& job : jobs) {
      if (job.run_dir.empty()) continue;
      const bool ran = job.ok || !job.error.empty();
      if (!ran) continue;  // not reached after an interrupt
      failed = failed || !job.ok;
      runs.push_back(job);
    }
    mode_runs.push_back(mode_run);
    if (mode_run.interrupted) {
      failed = true;
      break;
    }
  }

  const auto cells = aggregate(runs);
  const auto markdown = campaign_markdown(spec, mode_runs, cells);
  try {
    sim::write_text_file(out_dir / "campaign.md", markdown);
    write_csv(out_dir / "campaign.csv", spec, runs);
    write_plot(out_dir, spec, mode_runs, cells);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 1;
  }
  std::printf("%s\n", markdown.c_str());
  std::printf("campaign directory: %s (%.0f s)\n", out_dir.string().c_str(), seconds_since(campaign_started));
  return failed ? 1 : 0;
}

}  // namespace swarmloc::orchestrator
