#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iomanip>
#include <sstream>

#include "campaign_internal.hpp"
#include "swarmloc/rundir/plots.hpp"
#include "swarmloc/runtime/output_file.hpp"

namespace swarmloc::research::campaign_detail {
namespace {

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

}  // namespace

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

namespace {

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

/// The pass/fail line of the spec's check.
void check_line(std::ostringstream& md, const CampaignSpec& spec, const std::string& mode,
                const std::map<CellKey, CellStats>& cells) {
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
      md << " " << spec.algorithms[a].label << (spec.variants.size() > 1 ? " " + spec.variants[v].label : "")
         << " " << fmt("%.2f", ratio) << " [" << fmt("%.2f", median) << "]"
         << (std::isfinite(ratio) && ratio <= spec.check_max_ratio ? " pass" : " FAIL") << ";";
    }
  }
  md << "\n\n";
}

/// Reference runs still falling at the horizon: their ratios compare transients.
void unsettled_line(std::ostringstream& md, const CampaignSpec& spec, const std::string& mode,
                    const std::map<CellKey, CellStats>& cells) {
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

/// One mode's section: the four tables, the check and the unsettled references.
void mode_section(std::ostringstream& md, const CampaignSpec& spec, const ModeRun& run,
                  const std::map<CellKey, CellStats>& cells) {
  const auto& mode = run.mode;
  md << "## " << (mode == "sim" ? "Simulator" : "DDS (one OS process per agent)") << " — " << run.seeds
     << " seed" << (run.seeds == 1 ? "" : "s") << " per cell, wall " << fmt("%.0f", run.wall_s) << " s"
     << (run.interrupted ? " (interrupted)" : "") << "\n\n";
  md << "Final RMSE ÷ reference: ratio of the means over seeds [median over seeds of the per-seed ratio], "
        "with the final RMSE in metres (mean ± std over seeds):\n\n";
  table(md, spec, mode, cells, [](const CellStats& c) {
    if (c.runs == 0) return std::string("failed");
    return fmt("%.2f", c.ratio) + " [" + fmt("%.2f", c.seed_ratio_median) + "] (" + fmt("%.3g", c.rmse_mean) +
           " ± " + fmt("%.2g", c.rmse_std) + ")" +
           (c.failed > 0 ? " " + std::to_string(c.failed) + " failed" : "");
  });
  md << "Final RMSE / the run's bound (summary.json `bound`: the accumulated CRLB or posterior CRB of the "
        "algorithm's data; n/a: no bound):\n\n";
  table(md, spec, mode, cells, [](const CellStats& c) { return fmt("%.2f", c.rmse_mean / c.bound_mean); });
  md << "Time to converge (s):\n\n";
  table(md, spec, mode, cells, [](const CellStats& c) { return fmt("%.1f", c.converge_s_mean); });
  md << "Delivered fraction of inter-agent samples:\n\n";
  table(md, spec, mode, cells, [](const CellStats& c) { return fmt("%.3f", c.delivered_fraction); });
  if (spec.check_value) check_line(md, spec, mode, cells);
  unsettled_line(md, spec, mode, cells);
}

}  // namespace

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
  for (const auto& run : modes) mode_section(md, spec, run, cells);
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
  runtime::write_text_file(path, out.str());
}

namespace {

/// A data file's quoted column cannot hold a double quote.
std::string without_double_quotes(std::string text) {
  std::replace(text.begin(), text.end(), '"', '\'');
  return text;
}

/// The x of each swept value: the value itself if every value is a number, else its index.
std::vector<double> plot_xs(const CampaignSpec& spec, bool& numeric) {
  numeric = true;
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
  return xs;
}

/// One plotted line: its data block in campaign_plot.dat, title, and algorithm and variant (its style).
struct PlotSeries {
  int block;
  std::string title;
  std::size_t algorithm, variant;
};

/// One mode's data blocks (a line per algorithm × variant); `block` counts the blocks written so far.
std::vector<PlotSeries> plot_data(std::ostringstream& data, const CampaignSpec& spec, const ModeRun& run,
                                  const std::map<CellKey, CellStats>& cells, const std::vector<double>& xs,
                                  int& block) {
  std::vector<PlotSeries> series;
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
      series.push_back(
          {block++, spec.algorithms[a].label + (spec.variants.size() > 1 ? " " + spec.variants[v].label : ""),
           a, v});
    }
  }
  return series;
}

/// One mode's two panels: final RMSE ÷ reference (panel 0) and time to converge (panel 1).
void plot_panels(std::ostringstream& gp, const CampaignSpec& spec, const ModeRun& run,
                 const std::vector<PlotSeries>& series, bool numeric) {
  const std::string where = run.mode == "sim" ? "simulator" : "DDS";
  const std::string xtics = numeric ? "" : ":xtic(4)";
  for (int panel = 0; panel < 2; ++panel) {
    // Log scale for the ratio: one run in a wrong local minimum (×30) must not flatten every other line.
    gp << (panel == 0 ? "set logscale y\n" : "unset logscale y\n");
    // Labels come from the spec: quoted for gnuplot, never pasted into a command.
    gp << "set title "
       << rundir::gnuplot_quote((panel == 0 ? "final RMSE ÷ reference (" : "time to converge, s (") + where +
                                ")")
       << "\n"
       << "set xlabel " << rundir::gnuplot_quote(spec.swept_key) << "\n"
       << "set ylabel "
       << rundir::gnuplot_quote(panel == 0 ? "RMSE ÷ RMSE at " + spec.swept_values.front() : "s") << "\n"
       << "plot ";
    for (std::size_t s = 0; s < series.size(); ++s) {
      gp << (s ? ", \\\n     " : "") << "'campaign_plot.dat' index " << series[s].block
         << " using 1:" << (panel == 0 ? 2 : 3) << xtics << " with linespoints lc " << series[s].algorithm + 1
         << " dt " << series[s].variant + 1 << " pt " << series[s].algorithm + 4 << " title "
         << rundir::gnuplot_quote(series[s].title);
    }
    if (panel == 0 && spec.check_value) {
      gp << ", \\\n     " << spec.check_max_ratio << " with lines lc rgb 'gray' dt 3 title '"
         << spec.check_max_ratio << "×'";
    }
    gp << "\n";
  }
}

}  // namespace

void write_plot(const std::filesystem::path& directory, const CampaignSpec& spec,
                const std::vector<ModeRun>& modes, const std::map<CellKey, CellStats>& cells) {
  bool numeric = true;
  const auto xs = plot_xs(spec, numeric);
  std::ostringstream data;
  data << std::setprecision(9);
  std::ostringstream gp;
  gp << "# Made by `swarmloc campaign`; run `gnuplot campaign.gp` in this directory to redraw.\n"
     << "set terminal pngcairo size 1400," << 450 * std::max<std::size_t>(1, modes.size()) << " font ',10'\n"
     << "set output 'campaign.png'\nset grid\nset key outside right top\n"
     << "set multiplot layout " << modes.size() << ",2\n";
  int block = 0;
  for (const auto& run : modes) {
    const auto series = plot_data(data, spec, run, cells, xs, block);
    plot_panels(gp, spec, run, series, numeric);
  }
  gp << "unset multiplot\n";
  runtime::write_text_file(directory / "campaign_plot.dat", data.str());
  runtime::write_text_file(directory / "campaign.gp", gp.str());
  rundir::run_gnuplot(directory, "campaign.gp", {"campaign.png"});
}

}  // namespace swarmloc::research::campaign_detail
