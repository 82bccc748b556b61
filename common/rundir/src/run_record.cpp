#include "swarmloc/rundir/run_record.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <functional>
#include <iomanip>
#include <limits>
#include <numeric>
#include <set>
#include <sstream>
#include <utility>

#include "swarmloc/rundir/plots.hpp"
#include "swarmloc/rundir/tum_export.hpp"

namespace swarmloc::rundir {
namespace {

nlohmann::json number_or_null(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json();
}

/// What prepare_run_directory may clear with --force: a directory an earlier run wrote.
bool looks_like_run_directory(const std::filesystem::path& directory) {
  std::error_code ec;
  return std::filesystem::exists(directory / "scenario.yaml", ec) ||
         std::filesystem::exists(directory / "summary.json", ec) ||
         std::filesystem::is_directory(directory / "logs", ec);
}

/// `name` as one path component: no '/', no control character, no leading '.', at most 100 bytes.
std::string path_component(const std::string& name) {
  std::string safe;
  for (const char c : name.substr(0, 100)) {
    const auto byte = static_cast<unsigned char>(c);
    safe += (c == '/' || byte < 0x20 || byte == 0x7f) ? '_' : c;
  }
  while (!safe.empty() && safe.front() == '.') safe.front() = '_';
  return safe.empty() ? std::string("run") : safe;
}

/// The agents whose estimate at the final scored step carries the self-check's flag (docs/algorithms.md
/// §1.6). The rows are in step order: only the tail is read.
std::set<AgentId> flagged_at_final_step(const RunRecord& record) {
  std::set<AgentId> flagged;
  const StepMetrics* last = record.final_metrics();
  if (last == nullptr) return flagged;
  const auto& rows = record.estimates;
  for (auto row = rows.rbegin(); row != rows.rend() && row->step >= last->step; ++row) {
    if (row->step == last->step && row->estimate.inconsistent) flagged.insert(row->agent);
  }
  return flagged;
}

}  // namespace

LinkTotals link_totals(const RunRecord& record) {
  LinkTotals totals;
  for (const auto& [key, link] : record.links) {
    totals.sent += link.sent();
    totals.arrived += link.arrived;
    totals.delivered += link.delivered;
    totals.dropped_injected += link.dropped_injected;
    totals.rejected += link.rejected;
    totals.delivered_in_steps += link.delivered_in_steps;
  }
  return totals;
}

void compute_run_bounds(RunRecord& record, const world::World& world) {
  record.crlb = world::scenario_crlb(world, record.scenario);
  record.bound = world::run_bound(world, record.scenario, record.crlb);
  record.recorded = world.recorded;
  record.optimum_data = std::make_shared<world::OptimumAccumulator>(world, record.scenario);
  record.optimum = record.optimum_data->result();
}

void set_step_bounds(const RunRecord& record, StepMetrics& metrics) {
  metrics.crlb_rmse_m = record.crlb.accumulated_rmse_m(static_cast<double>(metrics.step + 1));
  metrics.bound_rmse_m = record.bound.rmse_at(metrics.step);
  metrics.bound_all_data_rmse_m = record.bound.all_data_rmse_at(metrics.step);
}

nlohmann::json bound_json(const RunRecord& record) {
  const world::RunBound& bound = record.bound;
  const StepMetrics* last = record.final_metrics();
  const double rmse = last != nullptr ? last->bound_rmse_m : std::numeric_limits<double>::quiet_NaN();
  nlohmann::json block = {{"kind", std::string(world::to_string(bound.kind))}};
  if (bound.kind == world::BoundKind::kNone) {
    block["reason"] = bound.reason;
    return block;
  }
  block["data"] = std::string(world::to_string(bound.draws));
  block["anchors"] = std::string(world::to_string(bound.anchors));
  block["rmse_m"] = number_or_null(rmse);
  block["all_data_rmse_m"] = last != nullptr ? number_or_null(last->bound_all_data_rmse_m) : nlohmann::json();
  block["ratio"] = last != nullptr ? number_or_null(last->errors.rmse_m / rmse) : nlohmann::json();
  return block;
}

WholeRunError whole_run_error(const RunRecord& record) {
  double squared_sum = 0.0;
  WholeRunError whole;
  for (const auto& m : record.metrics) {
    // A step with a broken estimate is scored, at +inf: the whole run's figure must not hide it.
    if (m.errors.scored == 0 && m.errors.non_finite == 0) continue;
    squared_sum += m.errors.rmse_m * m.errors.rmse_m;
    ++whole.scored_steps;
  }
  if (whole.scored_steps > 0) whole.rmse_m = std::sqrt(squared_sum / static_cast<double>(whole.scored_steps));
  if (record.recorded == nullptr) return whole;
  world::MeanNees nees3;
  for (const auto& row : record.estimates) {
    if (!row.estimate.heading || !row.truth.allFinite()) continue;
    nees3.add(world::pose_nees(row.estimate, row.truth, record.recorded->truth_heading(row.agent, row.step)));
  }
  whole.nees3 = nees3.mean();
  whole.nees3_samples = nees3.count;
  return whole;
}

NonFiniteEstimates non_finite_estimates(const RunRecord& record) {
  NonFiniteEstimates broken;
  for (const auto& m : record.metrics) {
    if (m.errors.non_finite == 0) continue;
    if (broken.steps++ == 0) broken.first_step = m.step;
    broken.most_agents = std::max(broken.most_agents, m.errors.non_finite);
  }
  return broken;
}

namespace {

/// summary.json's "final" block: the last scored step's figures.
nlohmann::json final_block(const RunRecord& record) {
  nlohmann::json final_json = nlohmann::json::object();
  if (const StepMetrics* last = record.final_metrics(); last != nullptr) {
    final_json["step"] = last->step;
    final_json["rmse_m"] = number_or_null(last->errors.rmse_m);
    final_json["mean_error_m"] = number_or_null(last->errors.mean_error_m);
    final_json["max_error_m"] = number_or_null(last->errors.max_error_m);
    final_json["nees"] = number_or_null(last->errors.nees);
    final_json["nees_agents"] = last->errors.nees_agents;
    final_json["scored_agents"] = last->errors.scored;
    final_json["missing_agents"] = last->errors.missing;
    final_json["non_finite_agents"] = last->errors.non_finite;
    final_json["lost_agents"] = last->lost;
    final_json["flagged_agents"] = last->errors.flagged;  // self-check verdicts, docs/algorithms.md §1.6
    final_json["crlb_rmse_m"] = number_or_null(last->crlb_rmse_m);
    if (world::measurement_kinds(record.scenario.algorithm.name).field) {
      final_json["field_rmse"] = number_or_null(last->errors.field_rmse);
      final_json["field_scored_agents"] = last->errors.field_scored;
    }
  }
  final_json["crlb_single_snapshot_rmse_m"] = number_or_null(record.crlb.single_snapshot_rmse_m);
  return final_json;
}

/// A baseline's whole-run RMSE from record.extra["baselines"] (replay --mrclam), NaN without one.
double baseline_rmse(const RunRecord& record, const char* name) {
  const auto baselines = record.extra.find("baselines");
  if (baselines == record.extra.end() || !baselines->is_object())
    return std::numeric_limits<double>::quiet_NaN();
  const auto baseline = baselines->find(name);
  if (baseline == baselines->end() || !baseline->contains("rmse_m") || !(*baseline)["rmse_m"].is_number())
    return std::numeric_limits<double>::quiet_NaN();
  return (*baseline)["rmse_m"].get<double>();
}

/// The baselines the run's whole-run RMSE is compared with: (summary.json key, baseline, table label).
struct EfficiencyReference {
  const char* key;
  const char* baseline;
  const char* label;
};
constexpr EfficiencyReference kEfficiencyReferences[] = {
    {"efficiency_vs_centralized_ekf", "centralized_ekf", "RMSE / centralized EKF's (run)"},
    {"efficiency_vs_batch_smoother", "batch_smoother", "RMSE / batch smoother's (run)"},
};

/// summary.json's "whole_run" block: rmse_m and scored_steps; nees3 and nees3_samples when some estimate
/// has a heading to score; the efficiencies against the baselines a replay --mrclam computed.
nlohmann::json whole_run_json(const RunRecord& record, const WholeRunError& whole) {
  using nlohmann::json;
  json block = {{"rmse_m", whole.scored_steps > 0 ? number_or_null(whole.rmse_m) : json()},
                {"scored_steps", whole.scored_steps}};
  if (whole.nees3_samples > 0) {
    block["nees3"] = number_or_null(whole.nees3);
    block["nees3_samples"] = whole.nees3_samples;
  }
  for (const auto& reference : kEfficiencyReferences) {
    const double baseline = baseline_rmse(record, reference.baseline);
    if (std::isfinite(baseline)) block[reference.key] = number_or_null(whole.rmse_m / baseline);
  }
  return block;
}

}  // namespace

nlohmann::json summary_json(const RunRecord& record) {
  using nlohmann::json;
  json summary;
  summary["algorithm"] = record.scenario.algorithm.name;
  summary["mode"] = record.mode;
  summary["agents"] = record.agents;
  summary["anchors"] = record.anchors;
  summary["mean_degree"] = record.mean_degree;
  summary["dimensions"] = record.scenario.world.dimensions;
  summary["steps"] = record.metrics.size();
  summary["seed"] = record.scenario.seed;
  summary["scenario_hash"] = config::scenario_hash(record.scenario);
  const StepMetrics* last = record.final_metrics();
  summary["final"] = final_block(record);
  const auto whole = whole_run_error(record);
  summary["whole_run"] = whole_run_json(record, whole);
  const auto broken = non_finite_estimates(record);
  summary["non_finite_estimates"] = {{"steps", broken.steps},
                                     {"first_step", broken.steps > 0 ? json(broken.first_step) : json()},
                                     {"most_agents", broken.most_agents}};
  summary["crlb"] = {{"single_snapshot_rmse_m", number_or_null(record.crlb.single_snapshot_rmse_m)},
                     {"accumulated_rmse_m", last ? number_or_null(last->crlb_rmse_m) : json()},
                     {"localizable", record.crlb.localizable}};
  summary["bound"] = bound_json(record);
  summary["optimum"] = optimum_json(record);
  summary["efficiency"] = number_or_null(run_efficiency(record));
  const auto totals = link_totals(record);
  summary["links"] = {{"sent", totals.sent},
                      {"arrived", totals.arrived},
                      {"delivered", totals.delivered},
                      {"delivered_in_steps", totals.delivered_in_steps},
                      {"dropped_injected", totals.dropped_injected},
                      {"rejected", totals.rejected},
                      {"lost_in_transport", totals.sent >= totals.arrived ? totals.sent - totals.arrived : 0},
                      {"loss_probability", record.scenario.network.loss},
                      {"burst_mean_length", record.scenario.network.burst.mean_length}};
  json rejected = json::object();
  std::array<std::uint64_t, runtime::kRejectReasonCount> rejected_sum{};
  double cpu_sum = 0.0;
  int cpu_count = 0;
  for (const auto& agent : record.agent_summaries) {
    for (std::size_t r = 0; r < runtime::kRejectReasonCount; ++r)
      rejected_sum[r] += agent.rejected_by_reason[r];
    if (agent.cpu_s > 0.0) cpu_sum += agent.cpu_s, ++cpu_count;
  }
  for (std::size_t r = 0; r < runtime::kRejectReasonCount; ++r) {
    rejected[runtime::to_string(static_cast<runtime::RejectReason>(r))] = rejected_sum[r];
  }
  summary["rejected_by_reason"] = rejected;
  summary["processes"] = record.processes;
  summary["wall_s"] = record.wall_s;
  summary["cpu_per_agent_s"] = cpu_count > 0 ? json(cpu_sum / cpu_count) : json();
  // Agents report CPU since START, so normalize by the world phase's wall time (a DDS orchestrator that
  // cannot keep the rate runs longer than steps / rate).
  const double run_duration_s =
      record.world_phase_s > 0.0 ? record.world_phase_s
                                 : static_cast<double>(record.metrics.size()) / record.scenario.run.rate_hz;
  summary["cpu_per_agent_fraction"] =
      cpu_count > 0 && run_duration_s > 0.0 ? json(cpu_sum / cpu_count / run_duration_s) : json();
  if (record.world_phase_s > 0.0) summary["world_phase_s"] = record.world_phase_s;
  summary["interrupted"] = record.interrupted;
  for (const auto& [key, value] : record.extra.items()) summary[key] = value;
  return summary;
}

void create_output_directories(const std::filesystem::path& directory) {
  std::error_code ec;
  std::filesystem::create_directories(directory, ec);
  if (ec) throw runtime::OutputError(directory, "create directory", ec.value());
}

namespace {

/// metrics.csv: one row per scored world step.
std::string metrics_csv(const RunRecord& record) {
  std::ostringstream out;
  // A field world adds the field's error (joint_field); every other run keeps the nine columns.
  const bool field = world::measurement_kinds(record.scenario.algorithm.name).field;
  // New columns go last (`lost`, the run's bound, `non_finite`, the optimum), so older readers keep their
  // columns. The optimum and the efficiency are NaN off the optimum's checkpoints.
  out << "step,time_s,rmse_m,mean_error_m,max_error_m,crlb_rmse_m,nees,scored,missing"
      << (field ? ",field_rmse,lost" : ",lost")
      << ",bound_rmse_m,bound_all_data_rmse_m,non_finite,optimum_rmse_m,efficiency\n";
  out << std::setprecision(9);
  for (const auto& m : record.metrics) {
    out << m.step << ',' << m.time_s << ',' << m.errors.rmse_m << ',' << m.errors.mean_error_m << ','
        << m.errors.max_error_m << ',' << m.crlb_rmse_m << ',' << m.errors.nees << ',' << m.errors.scored
        << ',' << m.errors.missing;
    if (field) out << ',' << m.errors.field_rmse;
    out << ',' << m.lost << ',' << m.bound_rmse_m << ',' << m.bound_all_data_rmse_m << ','
        << m.errors.non_finite << ',' << m.optimum_rmse_m << ',' << m.errors.rmse_m / m.optimum_rmse_m
        << '\n';
  }
  return out.str();
}

}  // namespace

void write_run_directory(const std::filesystem::path& directory, const RunRecord& record,
                         const world::WorkControl& control) {
  create_output_directories(directory);
  // A summary.json of an earlier attempt must not vouch for this one while it is half written.
  std::error_code ignored;
  std::filesystem::remove(directory / "summary.json", ignored);
  runtime::write_text_file(directory / "scenario.yaml", config::to_yaml(record.scenario));
  runtime::write_text_file(directory / "seed", std::to_string(record.scenario.seed) + "\n");
  runtime::write_text_file(directory / "metrics.csv", metrics_csv(record));
  {
    // Large runs hold millions of rows: written in chunks, not built whole in memory.
    runtime::OutputFile file(directory / "estimates.csv");
    std::ostringstream out;
    // `inconsistent` (the self-check's verdict) comes last, so older readers keep their columns.
    // A 3-D world's z columns come last too; error_m is then the distance in space.
    const bool spatial = record.scenario.world.dimensions == 3;
    out << "step,agent,x_m,y_m,cov_xx,cov_xy,cov_yy,valid,truth_x_m,truth_y_m,error_m,inconsistent"
        << (spatial ? ",z_m,cov_xz,cov_yz,cov_zz,truth_z_m\n" : "\n");
    out << std::setprecision(9);
    std::size_t rows = 0;
    for (const auto& row : record.estimates) {
      const auto& e = row.estimate;
      out << row.step << ',' << row.agent << ',' << e.mean_m.x() << ',' << e.mean_m.y() << ','
          << e.covariance(0, 0) << ',' << e.covariance(0, 1) << ',' << e.covariance(1, 1) << ','
          << (e.valid ? 1 : 0) << ',' << row.truth.x() << ',' << row.truth.y() << ',' << row.error_m() << ','
          << (e.inconsistent ? 1 : 0);
      if (spatial) {
        const Altitude altitude = e.altitude.value_or(Altitude{std::numeric_limits<double>::quiet_NaN()});
        out << ',' << altitude.z_m << ',' << altitude.cross_m2.x() << ',' << altitude.cross_m2.y() << ','
            << altitude.variance_m2 << ',' << row.truth_z_m;
      }
      out << '\n';
      if (++rows % 4096 == 0) {
        file.write(out.view());
        out.str({});
      }
    }
    file.write(out.view());
    file.close();
  }
  {
    std::ostringstream out;
    out << "sender,receiver,sent,arrived,delivered,dropped_injected,rejected,delivered_in_steps\n";
    for (const auto& [key, link] : record.links) {
      out << key.first << ',' << key.second << ',' << link.sent() << ',' << link.arrived << ','
          << link.delivered << ',' << link.dropped_injected << ',' << link.rejected << ','
          << link.delivered_in_steps << '\n';
    }
    runtime::write_text_file(directory / "links.csv", out.str());
  }
  if (const std::string optimum = optimum_csv(record); !optimum.empty())
    runtime::write_text_file(directory / "optimum.csv", optimum);
  control.throw_if_cancelled();
  {
    std::ostringstream out;
    out << "agent,anchor,steps_run,samples_published,cpu_s,exit_code,samples_published_in_steps,fate,fate_"
           "step,"
           "fate_reason,flagged_final\n";
    const std::set<AgentId> flagged = flagged_at_final_step(record);
    for (const auto& a : record.agent_summaries) {
      std::string reason = a.fate_reason;
      std::replace(reason.begin(), reason.end(), ',', ';');
      out << a.agent << ',' << (a.anchor ? 1 : 0) << ',' << a.steps_run << ',' << a.samples_published << ','
          << a.cpu_s << ',' << (a.exit_code ? std::to_string(*a.exit_code) : "") << ','
          << a.samples_published_in_steps << ',' << a.fate << ','
          << (a.fate_step >= 0 ? std::to_string(a.fate_step) : "") << ',' << reason << ','
          << (flagged.contains(a.agent) ? 1 : 0) << '\n';
    }
    runtime::write_text_file(directory / "agents.csv", out.str());
  }
  control.throw_if_cancelled();
  write_tum_trajectories(directory, record, control);
  control.throw_if_cancelled();
  write_plots(directory, record);
  control.throw_if_cancelled();
  runtime::write_text_file_atomic(directory / "summary.json", summary_json(record).dump(2) + "\n");
}

namespace {

/// Empties a non-empty --out `directory` that holds an earlier run when `force` is set; refuses otherwise.
void clear_earlier_run(const std::filesystem::path& directory, std::filesystem::directory_iterator entries,
                       const std::string& where, bool force) {
  namespace fs = std::filesystem;
  const bool earlier_run = looks_like_run_directory(directory);
  if (!earlier_run) {
    throw config::ScenarioError(where + " is not empty and is not a swarmloc run directory; " +
                                (force ? "refusing to clear it" : "choose another directory"));
  }
  if (!force) {
    throw config::ScenarioError(where +
                                " is not empty (it holds an earlier run); pass --force to replace it, or "
                                "choose another directory");
  }
  std::error_code ec;
  std::vector<fs::path> contents;
  for (; entries != fs::directory_iterator(); entries.increment(ec)) {
    if (ec) break;
    contents.push_back(entries->path());
  }
  for (const auto& entry : contents) {
    if (ec) break;
    fs::remove_all(entry, ec);
  }
  if (ec) throw config::ScenarioError(where + ": cannot clear the earlier run: " + ec.message());
}

/// An existing --out path: it must be a directory, empty or (with `force`) holding an earlier run.
void prepare_existing_directory(const std::filesystem::path& directory,
                                const std::filesystem::file_status& status, const std::string& where,
                                bool force) {
  namespace fs = std::filesystem;
  if (!fs::is_directory(status)) throw config::ScenarioError(where + " exists and is not a directory");
  std::error_code ec;
  fs::directory_iterator entries(directory, ec);
  if (ec) throw config::ScenarioError(where + ": cannot list it: " + ec.message());
  if (entries != fs::directory_iterator()) clear_earlier_run(directory, std::move(entries), where, force);
}

/// Writable now, not after the run: a read-only mount or a missing permission is bad input (exit 2).
void check_writable(const std::filesystem::path& directory, const std::string& where) {
  const auto probe = directory / (".swarmloc-probe-" + std::to_string(::getpid()));
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) {
    throw config::ScenarioError(where + " is not writable: " + std::strerror(errno));
  }
  ::close(fd);
  if (::unlink(probe.c_str()) != 0) {
    throw config::ScenarioError(where + ": cannot remove " + probe.string() + ": " + std::strerror(errno));
  }
}

}  // namespace

void prepare_run_directory(const std::filesystem::path& directory, bool force) {
  namespace fs = std::filesystem;
  const std::string where = "--out: " + directory.string();
  std::error_code ec;
  const auto status = fs::status(directory, ec);
  if (ec && ec != std::errc::no_such_file_or_directory)
    throw config::ScenarioError(where + ": " + ec.message());
  if (fs::exists(status)) {
    prepare_existing_directory(directory, status, where, force);
  } else {
    fs::create_directories(directory, ec);
    if (ec) throw config::ScenarioError(where + ": cannot create it: " + ec.message());
  }
  check_writable(directory, where);
}

namespace {

/// The result table's bound: which one, its value, the RMSE / bound ratio, and the all-data bound.
void bound_rows(std::ostringstream& out, const RunRecord& record, const StepMetrics& last) {
  char line[256];
  const world::RunBound& bound = record.bound;
  if (bound.kind == world::BoundKind::kNone) {
    std::snprintf(line, sizeof line, "  %-34s %12s  (%s)\n", "bound", "none", bound.reason.c_str());
    out << line;
    return;
  }
  const std::string label =
      std::string(bound.kind == world::BoundKind::kPcrb ? "posterior CRB" : "CRLB, accumulated") + " (" +
      std::string(world::to_string(bound.draws)) + ")";
  std::snprintf(line, sizeof line, "  %-34s %12.4f m\n", label.c_str(), last.bound_rmse_m);
  out << line;
  std::snprintf(line, sizeof line, "  %-34s %12.2f  (%s)\n", "final RMSE / bound",
                last.errors.rmse_m / last.bound_rmse_m, std::string(world::to_string(bound.kind)).c_str());
  out << line;
  if (bound.draws != world::RangeDraws::kAllDraws) {
    std::snprintf(line, sizeof line, "  %-34s %12.4f m\n", "bound with all the data",
                  last.bound_all_data_rmse_m);
    out << line;
  }
}

/// The result table's optimum (docs/algorithms.md §1.3.2): its kind and RMSE, and the efficiency beside the
/// bound's ratio.
void optimum_rows(std::ostringstream& out, const RunRecord& record, const StepMetrics& last) {
  char line[256];
  const world::RunOptimum& optimum = record.optimum;
  if (optimum.kind == world::OptimumKind::kNone) {
    std::snprintf(line, sizeof line, "  %-34s %12s  (%s)\n", "optimum of the run's data", "none",
                  optimum.reason.c_str());
    out << line;
    return;
  }
  const std::string label = "optimum of its data (" + std::string(world::to_string(optimum.draws)) + ")";
  const world::OptimumPoint* point = optimum.at(last.step);
  // Solved from the run's own estimates: the data cannot rule out the basin the estimator found.
  const char* start = point != nullptr && point->from_estimates ? "  (in the estimates' basin)" : "";
  std::snprintf(line, sizeof line, "  %-34s %12.4f m%s\n", label.c_str(), last.optimum_rmse_m, start);
  out << line;
  std::snprintf(line, sizeof line, "  %-34s %12.2f  (%s)\n", "final RMSE / optimum (efficiency)",
                last.errors.rmse_m / last.optimum_rmse_m,
                std::string(world::to_string(optimum.kind)).c_str());
  out << line;
}

/// replay --mrclam: the baselines scored on the same steps (RMSE over the whole run), and the run's RMSE over
/// theirs; `row` prints one table row (label, value, unit).
void baseline_rows(const RunRecord& record, double whole_run_rmse_m,
                   const std::function<void(const char*, double, const char*)>& row) {
  const auto baselines = record.extra.find("baselines");
  if (baselines == record.extra.end()) return;
  for (const auto& [name, figures] : baselines->items()) {
    if (!figures.contains("rmse_m") || !figures["rmse_m"].is_number()) continue;
    std::string label = "baseline " + name;
    std::replace(label.begin(), label.end(), '_', ' ');
    char unit[64] = "m";
    if (figures.contains("nees3") && figures["nees3"].is_number())
      std::snprintf(unit, sizeof unit, "m  (NEES3 %.2f)", figures["nees3"].get<double>());
    row(label.c_str(), figures["rmse_m"].get<double>(), unit);
  }
  for (const auto& reference : kEfficiencyReferences) {
    const double baseline = baseline_rmse(record, reference.baseline);
    if (std::isfinite(baseline)) row(reference.label, whole_run_rmse_m / baseline, "");
  }
}

/// The table's verdict line on non-finite estimates.
std::string not_valid_line(const NonFiniteEstimates& broken) {
  return "  NOT VALID: non-finite (NaN/Inf) estimates at " + std::to_string(broken.steps) +
         " step(s) from step " + std::to_string(broken.first_step) + " (up to " +
         std::to_string(broken.most_agents) + " agent(s) at once): the results are not valid\n";
}

}  // namespace

std::string result_table(const RunRecord& record) {
  std::ostringstream out;
  const StepMetrics* last = record.final_metrics();
  const auto totals = link_totals(record);
  char line[256];
  out << "\n  swarmloc result: " << record.scenario.algorithm.name << " (" << record.mode << "), "
      << record.agents << " agents, " << record.anchors << " anchors, seed " << record.scenario.seed << "\n";
  out << "  ------------------------------------------------------------\n";
  auto row = [&](const char* name, double value, const char* unit) {
    std::snprintf(line, sizeof line, "  %-34s %12.4f %s\n", name, value, unit);
    out << line;
  };
  if (last != nullptr) {
    row("final RMSE", last->errors.rmse_m, "m");
    row("final mean error", last->errors.mean_error_m, "m");
    row("final max error", last->errors.max_error_m, "m");
    row(record.scenario.world.dimensions == 3 ? "final NEES (3 = consistent)" : "final NEES (2 = consistent)",
        last->errors.nees, "");
    if (last->errors.nees_agents < last->errors.scored) {  // some agents publish no covariance to judge
      const std::string over =
          std::to_string(last->errors.nees_agents) + " of " + std::to_string(last->errors.scored);
      std::snprintf(line, sizeof line, "  %-34s %12s\n", "  NEES over agents with covariance", over.c_str());
      out << line;
    }
    std::snprintf(line, sizeof line, "  %-34s %12d\n", "agents flagged by self-check", last->errors.flagged);
    out << line;
    // Whom the final figures cover: a killed, silent or broken agent is not hidden by a smaller mean.
    const int expected = last->errors.scored + last->errors.missing + last->errors.non_finite;
    const std::string covered = std::to_string(last->errors.scored) + " of " + std::to_string(expected);
    std::snprintf(line, sizeof line, "  %-34s %12s\n", "agents scored at the final step", covered.c_str());
    out << line;
    if (const auto broken = non_finite_estimates(record); broken.steps > 0) out << not_valid_line(broken);
    const WholeRunError whole = whole_run_error(record);
    row("RMSE over the whole run", whole.rmse_m, "m");
    if (whole.nees3_samples > 0) row("whole-run NEES3 (3 = consistent)", whole.nees3, "");
    if (world::measurement_kinds(record.scenario.algorithm.name).field)
      row("final field RMSE (per cell)", last->errors.field_rmse, "");
    bound_rows(out, record, *last);
    optimum_rows(out, record, *last);
    baseline_rows(record, whole.rmse_m, row);
    // The noise of what the algorithm measures (multipath path lengths use the range std).
    const auto kinds = world::measurement_kinds(record.scenario.algorithm.name);
    if (kinds.relative) row("noise std (relative, per axis)", record.scenario.noise.relative_std_m, "m");
    if (kinds.field) row("noise std (field reading)", record.scenario.noise.field_std, "");
    if (kinds.targets) row("noise std (target reading)", record.scenario.noise.target_std_m, "m");
    if (!kinds.relative && !kinds.targets) row("noise std (range)", record.scenario.noise.range_std_m, "m");
  }
  std::snprintf(line, sizeof line, "  %-34s %12llu\n", "messages sent",
                static_cast<unsigned long long>(totals.sent));
  out << line;
  std::snprintf(line, sizeof line, "  %-34s %12llu\n", "messages delivered",
                static_cast<unsigned long long>(totals.delivered));
  out << line;
  std::snprintf(line, sizeof line, "  %-34s %12llu  (%.1f %% of sent)\n", "messages dropped (injected)",
                static_cast<unsigned long long>(totals.dropped_injected),
                totals.sent > 0
                    ? 100.0 * static_cast<double>(totals.dropped_injected) / static_cast<double>(totals.sent)
                    : 0.0);
  out << line;
  std::snprintf(line, sizeof line, "  %-34s %12llu\n", "messages rejected (invalid)",
                static_cast<unsigned long long>(totals.rejected));
  out << line;
  row("wall time", record.wall_s, "s");
  if (record.interrupted) out << "  (interrupted)\n";
  return out.str();
}

std::filesystem::path default_run_directory(const config::Scenario& scenario) {
  return fresh_run_directory(scenario.name, "-seed" + std::to_string(scenario.seed));
}

std::filesystem::path fresh_run_directory(const std::string& name, const std::string& suffix) {
  const auto now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm utc{};
  gmtime_r(&now, &utc);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", &utc);
  const auto base = std::filesystem::path("runs") / (path_component(name) + "-" + stamp + suffix);
  auto candidate = base;
  std::error_code ec;
  for (int k = 2; std::filesystem::exists(candidate, ec); ++k)
    candidate = base.string() + "-" + std::to_string(k);
  return candidate;
}

}  // namespace swarmloc::rundir
