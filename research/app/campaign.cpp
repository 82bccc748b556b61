// `swarmloc-research campaign SPEC`: the command. The spec is read in campaign_spec.cpp, each run is made
// in campaign_cells.cpp, and the tables, CSV and plot are written in campaign_report.cpp.
#include "campaign.hpp"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <ctime>
#include <mutex>
#include <thread>

#include "campaign_internal.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/rundir/run_record.hpp"
#include "swarmloc/runtime/output_file.hpp"

namespace swarmloc::research {
namespace campaign_detail {
namespace {

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

/// The spec with the command line's choices (--mode, --seeds) applied; exits 2 (returned) on a bad spec.
std::optional<CampaignSpec> spec_as_run(const CampaignOptions& options) {
  try {
    auto spec = load_campaign_spec(options.spec_path);
    if (!options.mode.empty()) spec.modes = parse_mode_flag(options.mode);
    if (options.seeds > 0) {
      spec.seeds.clear();
      for (int k = 1; k <= options.seeds; ++k) spec.seeds.push_back(static_cast<std::uint64_t>(k));
      spec.dds_seeds.clear();
    }
    return spec;
  } catch (const config::ScenarioError& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return std::nullopt;
  }
}

/// Every run of one mode: each cell × seed, with its run directory.
std::vector<RunResult> mode_jobs(const CampaignSpec& spec, const std::string& mode,
                                 const std::vector<std::uint64_t>& seeds,
                                 const std::filesystem::path& out_dir) {
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
  return jobs;
}

/// Simulator cells are independent and deterministic in their seed: run them on every core.
template <typename Report>
void run_sim_jobs(const CampaignSpec& spec, std::vector<RunResult>& jobs, Report&& report) {
  const int threads =
      spec.threads > 0 ? spec.threads : static_cast<int>(std::max(1U, std::thread::hardware_concurrency()));
  std::atomic<std::size_t> next{0};
  std::vector<std::thread> pool;
  pool.reserve(static_cast<std::size_t>(threads));
  for (int t = 0; t < threads; ++t) {
    pool.emplace_back([&] {
      for (auto k = next++; k < jobs.size(); k = next++) {
        run_sim_cell(spec, jobs[k]);
        report(jobs[k]);
      }
    });
  }
  for (auto& thread : pool) thread.join();
}

/// DDS cells one at a time (each run already puts one process per agent on the machine); returns
/// whether a run was interrupted (the rest is not run).
template <typename Report>
bool run_dds_jobs(const CampaignSpec& spec, std::vector<RunResult>& jobs, const std::string& agent_binary,
                  Report&& report) {
  for (auto& job : jobs) {
    bool interrupted = false;
    run_dds_cell(spec, job, agent_binary, interrupted);
    report(job);
    if (interrupted) {
      std::fprintf(stderr, "campaign interrupted; writing what ran\n");
      return true;
    }
  }
  return false;
}

/// Runs one mode's cells; appends the runs that ran to `runs`, and sets `failed` if any failed.
ModeRun run_mode(const CampaignSpec& spec, const std::string& mode, const CampaignOptions& options,
                 const std::filesystem::path& out_dir, std::vector<RunResult>& runs, bool& failed) {
  const auto& seeds = mode == "dds" && !spec.dds_seeds.empty() ? spec.dds_seeds : spec.seeds;
  auto jobs = mode_jobs(spec, mode, seeds, out_dir);
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
    run_sim_jobs(spec, jobs, report);
  } else {
    mode_run.interrupted = run_dds_jobs(spec, jobs, options.agent_binary, report);
  }
  mode_run.wall_s = seconds_since(started);
  for (const auto& job : jobs) {
    if (job.run_dir.empty()) continue;
    const bool ran = job.ok || !job.error.empty();
    if (!ran) continue;  // not reached after an interrupt
    failed = failed || !job.ok;
    runs.push_back(job);
  }
  return mode_run;
}

}  // namespace
}  // namespace campaign_detail

int run_campaign(const CampaignOptions& options) {
  namespace detail = campaign_detail;
  const auto spec_or_error = detail::spec_as_run(options);
  if (!spec_or_error) return 2;
  const auto& spec = *spec_or_error;
  const auto out_dir = options.out_dir.empty() ? detail::default_campaign_directory(spec) : options.out_dir;
  try {
    rundir::create_output_directories(out_dir);
    runtime::write_text_file(out_dir / "spec.yaml", "# The campaign as run (swarmloc campaign " +
                                                        options.spec_path.string() + ")\n" +
                                                        campaign_spec_yaml(spec));
  } catch (const runtime::OutputError& error) {
    std::fprintf(stderr, "error: --out: %s\n", error.what());
    return 2;
  }

  std::vector<detail::RunResult> runs;
  std::vector<detail::ModeRun> mode_runs;
  bool failed = false;
  const auto campaign_started = detail::Clock::now();
  for (const auto& mode : spec.modes) {
    mode_runs.push_back(detail::run_mode(spec, mode, options, out_dir, runs, failed));
    if (mode_runs.back().interrupted) {
      failed = true;
      break;
    }
  }

  const auto cells = detail::aggregate(runs);
  const auto markdown = detail::campaign_markdown(spec, mode_runs, cells);
  try {
    runtime::write_text_file(out_dir / "campaign.md", markdown);
    detail::write_csv(out_dir / "campaign.csv", spec, runs);
    detail::write_plot(out_dir, spec, mode_runs, cells);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 1;
  }
  std::printf("%s\n", markdown.c_str());
  std::printf("campaign directory: %s (%.0f s)\n", out_dir.string().c_str(),
              detail::seconds_since(campaign_started));
  return failed ? 1 : 0;
}

}  // namespace swarmloc::research
