#include "swarmloc/rundir/plots.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iomanip>
#include <limits>
#include <map>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>

#include "swarmloc/rundir/external_program.hpp"
#include "swarmloc/runtime/output_file.hpp"

namespace swarmloc::rundir {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Whether `directory` can take a write the size of a plot: 0 if so, else the OS error (ENOSPC, EDQUOT,
/// EROFS, EFBIG). Tells a full disk from a gnuplot script error when a PNG is missing.
int room_for_a_plot(const std::filesystem::path& directory) {
  const auto probe = directory / (".swarmloc-room-probe-" + std::to_string(::getpid()));
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return errno;
  const std::string block(64 * 1024, '\0');
  int error = 0;
  for (std::size_t done = 0; done < block.size() && error == 0;) {
    const ssize_t wrote = ::write(fd, block.data() + done, block.size() - done);
    if (wrote < 0 && errno != EINTR) error = errno;
    if (wrote > 0) done += static_cast<std::size_t>(wrote);
  }
  if (error == 0 && ::fsync(fd) != 0) error = errno;
  if (::close(fd) != 0 && error == 0) error = errno;
  ::unlink(probe.c_str());
  return error;
}

/// A PNG is whole when it ends with its IEND chunk (a full disk leaves a truncated one); anything else
/// must be non-empty.
bool complete_output(const std::filesystem::path& path) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec || size == 0) return false;
  if (path.extension() != ".png") return true;
  static constexpr unsigned char kIend[12] = {0, 0, 0, 0, 'I', 'E', 'N', 'D', 0xAE, 0x42, 0x60, 0x82};
  if (size < sizeof kIend) return false;
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (file == nullptr) return false;
  unsigned char tail[sizeof kIend] = {};
  const bool read = std::fseek(file, -static_cast<long>(sizeof kIend), SEEK_END) == 0 &&
                    std::fread(tail, 1, sizeof tail, file) == sizeof tail;
  std::fclose(file);
  return read && std::memcmp(tail, kIend, sizeof kIend) == 0;
}

/// Each agent's newest row at the last recorded step (or its newest row overall if it missed that step).
std::map<AgentId, const EstimateRow*> final_rows(const RunRecord& record) {
  std::map<AgentId, const EstimateRow*> rows;
  for (const auto& row : record.estimates) {
    auto& slot = rows[row.agent];
    if (slot == nullptr || row.step >= slot->step) slot = &row;
  }
  return rows;
}

bool is_anchor(const RunRecord& record, AgentId agent) {
  const auto index = static_cast<std::size_t>(agent);
  return agent >= 0 && index < record.agent_summaries.size() && record.agent_summaries[index].anchor;
}

std::string header_title(const RunRecord& record) {
  std::ostringstream out;
  out << "swarmloc " << record.scenario.algorithm.name << " (" << record.mode << "), " << record.agents
      << " agents, " << record.anchors << " anchors, seed " << record.scenario.seed;
  return out.str();
}

std::string preamble(const std::string& output) {
  return "set datafile separator ','\nset terminal pngcairo size 900,640 enhanced font ',11'\nset grid\n"
         "set output " +
         gnuplot_quote(output) + "\n";
}

/// Which bound a plot draws (docs/algorithms.md §1.3.1), e.g. "posterior CRB (own draws)" (no '_': the
/// enhanced terminal would take it for a subscript).
std::string bound_label(const RunRecord& record) {
  const world::RunBound& bound = record.bound;
  std::string draws(world::to_string(bound.draws));
  std::replace(draws.begin(), draws.end(), '_', ' ');
  const std::string kind = bound.kind == world::BoundKind::kPcrb ? "posterior CRB" : "CRLB, accumulated";
  return kind + " (" + draws + ")";
}

/// Whether the run's optimum was solved at some scored step (plots/optimum.csv has rows).
bool has_optimum_points(const RunRecord& record) {
  return std::any_of(record.metrics.begin(), record.metrics.end(),
                     [](const StepMetrics& m) { return std::isfinite(m.optimum_rmse_m); });
}

/// "optimum of the run's data (batch ML, all draws)" (no '_': the enhanced terminal's subscript).
std::string optimum_label(const RunRecord& record) {
  std::string kind(world::to_string(record.optimum.kind));
  std::string draws(world::to_string(record.optimum.draws));
  std::replace(kind.begin(), kind.end(), '_', ' ');
  std::replace(draws.begin(), draws.end(), '_', ' ');
  return "optimum of the run's data (" + kind + ", " + draws + ")";
}

std::string error_script(const RunRecord& record) {
  // metrics.csv: the bound columns come after `lost` (run_record.cpp), one further on in a field world.
  const int bound_column = world::measurement_kinds(record.scenario.algorithm.name).field ? 12 : 11;
  const bool has_bound = record.bound.kind != world::BoundKind::kNone;
  std::ostringstream gp;
  gp << preamble("error.png") << "set key top right box opaque\nset logscale y\n"
     << "set xlabel 'world step'\nset ylabel 'position error [m] (log scale)'\n"
     << "set title \"" << header_title(record) << "\\nlocalization error vs "
     << (has_bound ? "the " + bound_label(record) : "no bound (" + record.bound.reason + ")") << "\"\n"
     << "plot '../metrics.csv' using 1:3 skip 1 with lines lw 2 lc rgb '#1f77b4' title 'RMSE', "
        "'' using 1:4 skip 1 with lines lc rgb '#2ca02c' title 'mean error', "
        "'' using 1:5 skip 1 with lines lc rgb '#ff7f0e' title 'max error'";
  if (has_bound) {
    gp << ", '' using 1:" << bound_column << " skip 1 with lines dt 2 lw 2 lc rgb 'black' title '"
       << bound_label(record) << "'";
    if (record.bound.draws != world::RangeDraws::kAllDraws) {
      gp << ", '' using 1:" << bound_column + 1
         << " skip 1 with lines dt 3 lw 1 lc rgb 'gray40' title 'the same bound with all the data'";
    }
  }
  if (has_optimum_points(record)) {
    gp << ", 'optimum.csv' using 1:3 skip 1 with linespoints pt 7 ps 0.6 lw 1.5 lc rgb '#d62728' title "
       << gnuplot_quote(optimum_label(record));
  }
  gp << "\n";
  return gp.str();
}

/// plots/efficiency.gp: the RMSE over the optimum of the run's own data at its solved steps, beside the
/// RMSE over the bound (docs/algorithms.md §1.3.2).
std::string efficiency_script(const RunRecord& record) {
  std::ostringstream gp;
  gp << preamble("efficiency.png") << "set key top right box opaque\nset logscale y\n"
     << "set xlabel 'world step'\nset ylabel 'RMSE / reference (log scale)'\n"
     << "set title \"" << header_title(record) << "\\nefficiency: RMSE over the " << optimum_label(record)
     << "\"\n"
     << "plot 1 with lines dt 2 lw 1 lc rgb 'black' title 'the optimum of the run''s data (1)', "
        "'optimum.csv' using 1:4 skip 1 with linespoints pt 7 ps 0.6 lw 2 lc rgb '#d62728' "
        "title 'RMSE / optimum (efficiency)'";
  if (record.bound.kind != world::BoundKind::kNone) {
    gp << ", '' using 1:5 skip 1 with linespoints pt 6 ps 0.6 lw 1 lc rgb 'gray40' title 'RMSE / "
       << bound_label(record) << "'";
  }
  gp << "\n";
  return gp.str();
}

std::string nees_script(const RunRecord& record) {
  const std::string d = std::to_string(record.scenario.world.dimensions);  // the NEES expected per agent
  std::ostringstream gp;
  gp << preamble("nees.png") << "set key top right box opaque\nset logscale y\n"
     << "set xlabel 'world step'\nset ylabel 'mean NEES (log scale)'\n"
     << "set title \"" << header_title(record) << "\\nmean NEES over the scored agents (" << d
     << " = consistent), 95 % chi-square band\"\n"
     << "plot 'nees_band.csv' using 1:3:4 with filledcurves fs transparent solid 0.25 noborder "
        "lc rgb '#2ca02c' title '95 % band [χ²_{"
     << d << "n}(0.025), χ²_{" << d << "n}(0.975)]/n', " << d
     << " with lines dt 2 lw 2 lc rgb 'black' title 'expected (" << d
     << ")', '' using 1:2 with lines lw 2 lc rgb '#1f77b4' title 'NEES'\n";
  return gp.str();
}

/// An agent that died or stalled (DDS runs): its last estimate is not a living agent's, so it is drawn
/// apart and its links grey.
bool is_lost(const RunRecord& record, AgentId agent) {
  const auto index = static_cast<std::size_t>(agent);
  return agent >= 0 && index < record.agent_summaries.size() && record.agent_summaries[index].fate != "ok";
}

std::string positions_script(const RunRecord& record, bool have_links, bool have_lost_links,
                             bool have_ellipses, double magnification) {
  std::ostringstream gp;
  gp << preamble("positions.png") << "set size ratio -1\nset key outside bottom center horizontal box\n"
     << "set xlabel 'x [m]'\nset ylabel 'y [m]'\n"
     << "set title \"" << header_title(record) << "\\nfinal positions with 95 % covariance ellipses\"\n"
     << "set palette defined (0 '#d62728', 0.5 '#ff7f0e', 1 '#2ca02c')\nset cbrange [0:1]\n"
     << "set cblabel 'link delivered fraction (delivered / sent)'\n";
  gp << "plot ";
  if (have_links) {
    gp << "'link_segments.csv' using 1:2:($3-$1):($4-$2):5 with vectors nohead lw 1 lc palette "
          "title 'link (colour: delivered fraction)', ";
  }
  if (have_lost_links) {
    gp << "'lost_link_segments.csv' using 1:2:($3-$1):($4-$2) with vectors nohead lw 1 dt 2 lc rgb '#7f7f7f' "
          "title 'link of a lost agent', ";
  }
  if (have_ellipses) {
    gp << "'ellipses.csv' using 3:4 with lines lw 1.5 lc rgb '#9467bd' title '95 % ellipse";
    if (magnification != 1.0) gp << " (drawn ×" << magnification << ")";
    gp << "', ";
  }
  gp << "'final_positions.csv' using ($2==0?$3:1/0):4 skip 1 with points pt 6 ps 1.6 lw 1.5 lc rgb 'black' "
        "title 'truth', "
        "'' using ($2==0&&$8==0?$5:1/0):6 skip 1 with points pt 7 ps 0.7 lc rgb '#1f77b4' title 'estimate', "
        "'' using ($2==1?$3:1/0):4 skip 1 with points pt 5 ps 1.6 lc rgb '#d62728' title 'anchor'";
  bool lost = false;
  for (const auto& agent : record.agent_summaries) lost = lost || agent.fate != "ok";
  if (lost) {
    gp << ", '' using ($8==1?$3:1/0):4 skip 1 with points pt 2 ps 2.2 lw 2 lc rgb '#d62728' "
          "title 'lost agent (died or stalled; not scored)'";
  }
  gp << "\n";
  return gp.str();
}

/// 3-D runs: the side view, x across and z up (final_positions.csv columns 9-11), with z's 95 % interval.
std::string altitude_script(const RunRecord& record, double magnification) {
  std::ostringstream gp;
  gp << preamble("altitude.png") << "set size ratio -1\nset key outside bottom center horizontal box\n"
     << "set xlabel 'x [m]'\nset ylabel 'z [m]'\n"
     << "set title \"" << header_title(record) << "\\nfinal positions, side view (x against altitude)\"\n";
  gp << "plot 'final_positions.csv' using ($2==0?$3:1/0):9 skip 1 with points pt 6 ps 1.6 lw 1.5 "
        "lc rgb 'black' title 'truth', "
        "'' using ($2==0&&$8==0?$5:1/0):10:("
     << 1.96 * magnification
     << "*$11) skip 1 with yerrorbars pt 7 ps 0.7 lc rgb '#1f77b4' title 'estimate, 95 % interval of z";
  if (magnification != 1.0) gp << " (drawn ×" << magnification << ")";
  gp << "', '' using ($2==1?$3:1/0):9 skip 1 with points pt 5 ps 1.6 lc rgb '#d62728' title 'anchor'\n";
  return gp.str();
}

std::string histogram_script(const RunRecord& record, int agents, int most, double mean_m, double rmse_m,
                             double bound_m) {
  std::ostringstream gp;
  gp << std::setprecision(4);
  gp << preamble("error_histogram.png")
     << "set key top right box opaque\nset style fill solid 0.6 border -1\n"
     << "set xlabel 'final position error [m]'\nset ylabel 'agents'\nset xrange [0:*]\n"
     << "set yrange [0:" << most + 1 + most / 3 << "]\nset ytics " << std::max(1, (most + 1) / 8) << "\n"
     << "set title \"" << header_title(record) << "\\nfinal error of " << agents
     << " non-anchor agents: mean " << mean_m << " m, RMSE " << rmse_m << " m\"\n";
  std::string extra;
  if (std::isfinite(rmse_m)) {
    gp << "set arrow 1 from " << rmse_m << ", graph 0 to " << rmse_m
       << ", graph 1 nohead dt 2 lw 2 lc rgb 'black' front\n";
    extra += ", NaN with lines dt 2 lw 2 lc rgb 'black' title 'RMSE'";
  }
  if (std::isfinite(bound_m) && bound_m > 0.0) {
    gp << "set arrow 2 from " << bound_m << ", graph 0 to " << bound_m
       << ", graph 1 nohead dt 3 lw 2 lc rgb '#d62728' front\n";
    extra += ", NaN with lines dt 3 lw 2 lc rgb '#d62728' title '" + bound_label(record) + "'";
  }
  gp << "plot 'error_histogram.csv' using 3:4:($2-$1) skip 1 with boxes lc rgb '#1f77b4' title 'agents per "
        "bin'"
     << extra << '\n';
  return gp.str();
}

}  // namespace

double normal_quantile(double p) {
  if (!(p > 0.0 && p < 1.0)) return kNaN;
  static constexpr double a[] = {-3.969683028665376e+01, 2.209460984245205e+02,  -2.759285104469687e+02,
                                 1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
  static constexpr double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                                 6.680131188771972e+01, -1.328068155288572e+01};
  static constexpr double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                                 -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
  static constexpr double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                                 3.754408661907416e+00};
  constexpr double p_low = 0.02425;
  if (p < p_low) {
    const double q = std::sqrt(-2.0 * std::log(p));
    return (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
           ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0);
  }
  if (p > 1.0 - p_low) return -normal_quantile(1.0 - p);
  const double q = p - 0.5;
  const double r = q * q;
  return (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
         (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0);
}

double chi_square_quantile(double p, double dof) {
  if (!(dof > 0.0)) return kNaN;
  const double h = 2.0 / (9.0 * dof);
  const double cube_root = 1.0 - h + normal_quantile(p) * std::sqrt(h);
  return dof * std::max(0.0, cube_root * cube_root * cube_root);
}

NeesBand nees_band(int agents, double coverage, int dimensions) {
  if (agents <= 0) return {kNaN, kNaN};
  const double n = static_cast<double>(agents);
  const double dof = dimensions * n;
  const double tail = 0.5 * (1.0 - coverage);
  return {chi_square_quantile(tail, dof) / n, chi_square_quantile(1.0 - tail, dof) / n};
}

std::vector<Vec2> covariance_ellipse(const Vec2& mean, const Mat2& covariance, double chi_square,
                                     int points) {
  std::vector<Vec2> curve;
  if (!mean.allFinite() || !covariance.allFinite() || points < 3 || !(chi_square > 0.0)) return curve;
  const Mat2 symmetric = 0.5 * (covariance + covariance.transpose());
  const Eigen::SelfAdjointEigenSolver<Mat2> solver(symmetric);
  if (solver.info() != Eigen::Success || !(solver.eigenvalues().minCoeff() > 0.0)) return curve;
  const Mat2 transform =
      solver.eigenvectors() * solver.eigenvalues().cwiseSqrt().asDiagonal() * std::sqrt(chi_square);
  curve.reserve(static_cast<std::size_t>(points) + 1);
  for (int k = 0; k <= points; ++k) {
    const double t = 2.0 * std::numbers::pi * static_cast<double>(k % points) / static_cast<double>(points);
    curve.push_back(mean + transform * Vec2(std::cos(t), std::sin(t)));
  }
  return curve;
}

namespace {

using FinalRows = std::map<AgentId, const EstimateRow*>;
using ScriptMap = std::map<std::string, std::string>;  // file name -> script

/// plots/optimum.csv: the steps the optimum was solved at, with the RMSE, the optimum, the efficiency and the
/// RMSE over the bound there; and efficiency.gp. Nothing without a solved step.
void add_optimum_plot(const std::filesystem::path& plots, const RunRecord& record, ScriptMap& scripts) {
  if (!has_optimum_points(record)) return;
  std::ostringstream out;
  out << "step,rmse_m,optimum_rmse_m,efficiency,bound_ratio\n" << std::setprecision(9);
  for (const auto& m : record.metrics) {
    if (!std::isfinite(m.optimum_rmse_m)) continue;
    out << m.step << ',' << m.errors.rmse_m << ',' << m.optimum_rmse_m << ','
        << m.errors.rmse_m / m.optimum_rmse_m << ',' << m.errors.rmse_m / m.bound_rmse_m << '\n';
  }
  runtime::write_text_file(plots / "optimum.csv", out.str());
  scripts["efficiency.gp"] = efficiency_script(record);
}

/// NEES with its per-step band (the number of scored agents can change from step to step).
void write_nees_band(const std::filesystem::path& plots, const RunRecord& record) {
  std::ostringstream out;
  out << "# step,nees,band_lower,band_upper,scored_agents\n" << std::setprecision(9);
  for (const auto& m : record.metrics) {
    const auto band = nees_band(m.errors.scored, 0.95, record.scenario.world.dimensions);
    out << m.step << ',' << m.errors.nees << ',' << band.lower << ',' << band.upper << ',' << m.errors.scored
        << '\n';
  }
  runtime::write_text_file(plots / "nees_band.csv", out.str());
}

/// The final positions' table and what the other plots draw from it.
struct FinalPositions {
  std::string csv;                                         ///< final_positions.csv
  std::vector<double> errors;                              ///< non-anchor agents' final errors
  std::vector<std::pair<Vec2, std::vector<Vec2>>> curves;  ///< estimate, ellipse
  std::vector<double> semi_major;                          ///< per curve
  double extent = 0.0;                                     ///< of the true positions
};

FinalPositions collect_final_positions(const RunRecord& record, const FinalRows& finals) {
  FinalPositions out;
  std::ostringstream positions;
  const bool spatial = record.scenario.world.dimensions == 3;
  positions << "agent,anchor,truth_x,truth_y,est_x,est_y,error_m,lost"
            << (spatial ? ",truth_z,est_z,z_std" : "") << '\n'
            << std::setprecision(9);
  Vec2 low = finals.begin()->second->truth, high = low;
  for (const auto& [agent, row] : finals) {
    const bool anchor = is_anchor(record, agent);
    const auto& e = row->estimate;
    positions << agent << ',' << (anchor ? 1 : 0) << ',' << row->truth.x() << ',' << row->truth.y() << ','
              << e.mean_m.x() << ',' << e.mean_m.y() << ',' << row->error_m() << ','
              << (is_lost(record, agent) ? 1 : 0);
    if (spatial) {
      const bool has_z = e.altitude.has_value();
      positions << ',' << row->truth_z_m << ',' << (has_z ? e.altitude->z_m : kNaN) << ','
                << (has_z && e.valid && e.altitude->variance_m2 >= 0.0 ? std::sqrt(e.altitude->variance_m2)
                                                                       : kNaN);
    }
    positions << '\n';
    low = low.cwiseMin(row->truth);
    high = high.cwiseMax(row->truth);
    if (anchor) continue;
    // Only an error there is: no ground truth (recorded gaps) or a broken estimate has none to bin.
    if (e.mean_m.allFinite() && row->truth.allFinite()) out.errors.push_back(row->error_m());
    if (!e.valid) continue;
    auto curve = covariance_ellipse(e.mean_m, e.covariance);
    if (curve.empty()) continue;
    double axis = 0.0;
    for (const auto& p : curve) axis = std::max(axis, (p - e.mean_m).norm());
    out.semi_major.push_back(axis);
    out.curves.emplace_back(e.mean_m, std::move(curve));
  }
  out.extent = (high - low).maxCoeff();
  out.csv = positions.str();
  return out;
}

/// Ellipses far smaller than the map are invisible: draw them magnified by a round factor (1, 2, 5 × 10^k)
/// so the median semi-major axis is at least 1.5 % of the map, and say so in the legend.
double ellipse_magnification(std::vector<double> semi_major, double extent) {
  double magnification = 1.0;
  if (!semi_major.empty() && extent > 0.0) {
    std::nth_element(semi_major.begin(),
                     semi_major.begin() + static_cast<std::ptrdiff_t>(semi_major.size() / 2),
                     semi_major.end());
    const double median = semi_major[semi_major.size() / 2];
    const double wanted = 0.015 * extent;
    if (median > 0.0 && median < wanted) {
      const double decade = std::pow(10.0, std::floor(std::log10(wanted / median)));
      for (double step : {1.0, 2.0, 5.0, 10.0}) {
        magnification = step * decade;
        if (magnification * median >= wanted) break;
      }
    }
  }
  return magnification;
}

/// ellipses.csv's text; `have_ellipses` tells whether it holds any curve.
std::string ellipses_csv(const std::vector<std::pair<Vec2, std::vector<Vec2>>>& curves, double magnification,
                         bool& have_ellipses) {
  std::ostringstream ellipses;
  ellipses << "# 95 % covariance ellipses (chi-square 2 dof = " << kChiSquare2Dof95
           << "), one block per non-anchor agent: x,y (true size), x_drawn,y_drawn (magnified x"
           << magnification << " about the estimate)\n"
           << std::setprecision(9);
  for (const auto& [mean, curve] : curves) {
    ellipses << '\n';
    for (const auto& p : curve) {
      const Vec2 drawn = mean + magnification * (p - mean);
      ellipses << p.x() << ',' << p.y() << ',' << drawn.x() << ',' << drawn.y() << '\n';
    }
    have_ellipses = true;
  }
  return ellipses.str();
}

struct LinkPlot {
  bool have_links = false;
  bool have_lost_links = false;
};

/// Links, undirected: both directions' counters pooled, drawn between the true positions.
LinkPlot write_link_segments(const std::filesystem::path& plots, const RunRecord& record,
                             const FinalRows& finals) {
  std::map<std::pair<AgentId, AgentId>, std::pair<std::uint64_t, std::uint64_t>> pooled;  // delivered, sent
  for (const auto& [key, link] : record.links) {
    const auto edge = std::minmax(key.first, key.second);
    auto& [delivered, sent] = pooled[{edge.first, edge.second}];
    delivered += link.delivered;
    sent += link.sent();
  }
  std::ostringstream segments;
  std::ostringstream lost_segments;
  segments << "# x1,y1,x2,y2,delivered_fraction,delivered,sent (agents a,b)\n" << std::setprecision(9);
  lost_segments << "# x1,y1,x2,y2 (links of a lost agent: its counters stopped when it was lost)\n"
                << std::setprecision(9);
  LinkPlot drawn;
  for (const auto& [edge, counts] : pooled) {
    const auto a = finals.find(edge.first);
    const auto b = finals.find(edge.second);
    if (a == finals.end() || b == finals.end() || counts.second == 0) continue;
    if (is_lost(record, edge.first) || is_lost(record, edge.second)) {
      lost_segments << a->second->truth.x() << ',' << a->second->truth.y() << ',' << b->second->truth.x()
                    << ',' << b->second->truth.y() << '\n';
      drawn.have_lost_links = true;
      continue;
    }
    const double fraction =
        std::min(1.0, static_cast<double>(counts.first) / static_cast<double>(counts.second));
    segments << a->second->truth.x() << ',' << a->second->truth.y() << ',' << b->second->truth.x() << ','
             << b->second->truth.y() << ',' << fraction << ',' << counts.first << ',' << counts.second
             << '\n';
    drawn.have_links = true;
  }
  runtime::write_text_file(plots / "link_segments.csv", segments.str());
  runtime::write_text_file(plots / "lost_link_segments.csv", lost_segments.str());
  return drawn;
}

/// Histogram of the non-anchor agents' final errors: its table, and its script into `scripts`.
void add_error_histogram(const std::filesystem::path& plots, const RunRecord& record,
                         const std::vector<double>& errors, ScriptMap& scripts) {
  const double largest = *std::max_element(errors.begin(), errors.end());
  const int bins =
      std::clamp(static_cast<int>(std::ceil(std::sqrt(static_cast<double>(errors.size())))), 5, 25);
  const double top = largest > 0.0 ? largest * 1.0001 : 1e-3;
  const double width = top / static_cast<double>(bins);
  std::vector<int> counts(static_cast<std::size_t>(bins), 0);
  double sum = 0.0, sum_sq = 0.0;
  for (double err : errors) {
    const auto bin = std::min(static_cast<std::size_t>(err / width), counts.size() - 1);
    ++counts[bin];
    sum += err;
    sum_sq += err * err;
  }
  std::ostringstream histogram;
  histogram << "bin_lo_m,bin_hi_m,bin_center_m,agents\n" << std::setprecision(9);
  for (std::size_t k = 0; k < counts.size(); ++k) {
    const double lo = width * static_cast<double>(k);
    histogram << lo << ',' << lo + width << ',' << lo + 0.5 * width << ',' << counts[k] << '\n';
  }
  runtime::write_text_file(plots / "error_histogram.csv", histogram.str());
  const double n = static_cast<double>(errors.size());
  const auto* last = record.final_metrics();
  scripts["error_histogram.gp"] = histogram_script(record, static_cast<int>(errors.size()),
                                                   *std::max_element(counts.begin(), counts.end()), sum / n,
                                                   std::sqrt(sum_sq / n), last ? last->bound_rmse_m : kNaN);
}

/// Final positions, ellipses, links and the error histogram: their tables, and their scripts into `scripts`.
void add_final_position_plots(const std::filesystem::path& plots, const RunRecord& record,
                              const FinalRows& finals, ScriptMap& scripts) {
  const FinalPositions positions = collect_final_positions(record, finals);
  const double magnification = ellipse_magnification(positions.semi_major, positions.extent);
  bool have_ellipses = false;
  const std::string ellipses = ellipses_csv(positions.curves, magnification, have_ellipses);
  runtime::write_text_file(plots / "final_positions.csv", positions.csv);
  runtime::write_text_file(plots / "ellipses.csv", ellipses);
  const LinkPlot links = write_link_segments(plots, record, finals);
  scripts["positions.gp"] =
      positions_script(record, links.have_links, links.have_lost_links, have_ellipses, magnification);
  if (!positions.errors.empty()) add_error_histogram(plots, record, positions.errors, scripts);
  if (record.scenario.world.dimensions == 3) scripts["altitude.gp"] = altitude_script(record, magnification);
}

/// Each script, and plots.gp that loads them all.
void write_scripts(const std::filesystem::path& plots, const ScriptMap& scripts) {
  std::ostringstream all;
  all << "# Makes every plot of this run: cd into plots/ and run `gnuplot plots.gp`.\n";
  for (const auto& [name, script] : scripts) {
    runtime::write_text_file(plots / name, script);
    all << "reset\nload " << gnuplot_quote(name) << "\n";
  }
  runtime::write_text_file(plots / "plots.gp", all.str());
}

/// Runs gnuplot on each script; false if any PNG is not made (or gnuplot is not installed).
bool render_scripts(const std::filesystem::path& plots, const ScriptMap& scripts) {
  bool ok = true;
  for (const auto& [name, script] : scripts) {
    const auto png = std::filesystem::path(name).replace_extension(".png").string();
    const auto result = run_gnuplot(plots, name, {png});
    if (result == GnuplotResult::kNotInstalled) {
      static std::atomic<bool> noted{false};
      if (!noted.exchange(true)) {
        std::fprintf(stderr,
                     "note: gnuplot is not installed; the plots/*.gp scripts are written, run "
                     "`gnuplot plots.gp` in plots/ to make the PNGs\n");
      }
      return false;
    }
    ok = ok && result == GnuplotResult::kDone;
  }
  return ok;
}

}  // namespace

bool write_plots(const std::filesystem::path& directory, const RunRecord& record) {
  const auto plots = directory / "plots";
  create_output_directories(plots);
  ScriptMap scripts;
  // A run without any scored step has nothing to plot over time (gnuplot would fail on empty data).
  if (!record.metrics.empty()) scripts["error.gp"] = error_script(record);
  write_nees_band(plots, record);
  if (!record.metrics.empty()) scripts["nees.gp"] = nees_script(record);
  add_optimum_plot(plots, record, scripts);
  const auto finals = final_rows(record);
  if (!finals.empty()) add_final_position_plots(plots, record, finals, scripts);
  write_scripts(plots, scripts);
  return render_scripts(plots, scripts);
}

std::string gnuplot_quote(std::string_view text) {
  std::string quoted = "'";
  for (const char c : text) {
    quoted += c;
    if (c == '\'') quoted += '\'';
  }
  return quoted + "'";
}

GnuplotResult run_gnuplot(const std::filesystem::path& directory, const std::string& script,
                          const std::vector<std::string>& outputs) {
  const auto gnuplot = find_program("gnuplot");
  if (!gnuplot) return GnuplotResult::kNotInstalled;
  // A PNG left over from an earlier attempt must not pass for this one.
  for (const auto& output : outputs) {
    std::error_code ignored;
    std::filesystem::remove(directory / output, ignored);
  }
  ProgramOptions options;
  options.working_directory = directory;
  options.stdin_path = options.stdout_path = options.stderr_path = "/dev/null";
  const auto status = run_program({gnuplot->string(), script}, options);
  for (const auto& output : outputs) {
    const auto path = directory / output;
    if (complete_output(path)) continue;
    // Probed before the partial PNG is removed, which would free the room it lacked.
    const int error = room_for_a_plot(directory);
    std::error_code ignored;
    std::filesystem::remove(path, ignored);  // no truncated PNG passes for a plot later
    if (error != 0) throw runtime::OutputError(path, "write", error);
    if (status.succeeded()) throw runtime::OutputError(path, "write (gnuplot left it incomplete)", EIO);
    std::fprintf(stderr, "warning: gnuplot %s on %s; %s not made\n", status.describe().c_str(),
                 (directory / script).c_str(), path.c_str());
    return GnuplotResult::kFailed;
  }
  if (!status.succeeded()) {
    std::fprintf(stderr, "warning: gnuplot %s on %s\n", status.describe().c_str(),
                 (directory / script).c_str());
    return GnuplotResult::kFailed;
  }
  return GnuplotResult::kDone;
}

}  // namespace swarmloc::rundir
