#include "swarmloc/rundir/murp_run.hpp"

#include <cmath>
#include <iomanip>
#include <map>
#include <numbers>
#include <sstream>

#include "swarmloc/rundir/plots.hpp"
#include "swarmloc/rundir/run_record.hpp"
#include "swarmloc/runtime/output_file.hpp"

namespace swarmloc::rundir {
namespace {

namespace uwb = estimators::uwb;
using PairKey = std::pair<AgentId, AgentId>;

std::string pair_name(const PairKey& pair) {
  return std::to_string(pair.first) + "->" + std::to_string(pair.second);
}

nlohmann::json stats_json(const world::RelativeErrorStats& stats) {
  return {{"windows", stats.windows},
          {"position_mae_m", stats.position_mae_m()},
          {"position_rmse_m", stats.position_rmse_m()},
          {"heading_mae_deg", stats.heading_mae_deg()},
          {"range_normalized_mae", stats.range_normalized_mae()},
          {"mean_distance_m", stats.mean_distance_m()}};
}

/// The truth of each row (NaN pose where its window has none for the pair).
uwb::RelativePose truth_of(const std::vector<world::MurpTeamWindow>& windows,
                           const world::RelativeEstimateRow& row) {
  if (row.window >= 0 && row.window < static_cast<std::int64_t>(windows.size())) {
    const auto& truth = windows[static_cast<std::size_t>(row.window)].truth;
    if (const auto found = truth.find({row.base, row.target}); found != truth.end()) return found->second;
  }
  return {Vec3::Constant(std::nan("")), std::nan("")};
}

double window_time(const std::vector<world::MurpTeamWindow>& windows, std::int64_t window) {
  return window >= 0 && window < static_cast<std::int64_t>(windows.size())
             ? windows[static_cast<std::size_t>(window)].time_s
             : std::nan("");
}

void write_relative_csv(const std::filesystem::path& directory,
                        const std::vector<world::MurpTeamWindow>& windows,
                        const std::vector<world::RelativeEstimateRow>& rows) {
  std::ostringstream out;
  out << "window,time_s,base,target,x_m,y_m,z_m,heading_rad,std_x_m,std_y_m,std_z_m,std_heading_rad,"
         "truth_x_m,truth_y_m,truth_z_m,truth_heading_rad,distance_m,position_error_m,heading_error_deg\n";
  // Round-trip precision: a reader (the ROS 2 test, docs/ros2.md) can compare the estimates exactly.
  out << std::setprecision(17);
  for (const auto& row : rows) {
    const auto truth = truth_of(windows, row);
    const auto [position_error, heading_error] = world::relative_errors(row.estimate.pose, truth);
    const auto& p = row.estimate.pose.position_m;
    const Eigen::Vector4d std = row.estimate.covariance.diagonal().cwiseSqrt();
    out << row.window << ',' << window_time(windows, row.window) << ',' << row.base << ',' << row.target
        << ',' << p.x() << ',' << p.y() << ',' << p.z() << ',' << row.estimate.pose.heading_rad << ','
        << std(0) << ',' << std(1) << ',' << std(2) << ',' << std(3) << ',' << truth.position_m.x() << ','
        << truth.position_m.y() << ',' << truth.position_m.z() << ',' << truth.heading_rad << ','
        << truth.position_m.norm() << ',' << position_error << ',' << heading_error * 180.0 / std::numbers::pi
        << '\n';
  }
  runtime::write_text_file(directory / "relative.csv", out.str());
}

/// TUM line: time x y z qx qy qz qw (a heading about z).
void tum_line(std::ostringstream& out, double time, const uwb::RelativePose& pose) {
  const double half = 0.5 * pose.heading_rad;
  out << time << ' ' << pose.position_m.x() << ' ' << pose.position_m.y() << ' ' << pose.position_m.z()
      << " 0 0 " << std::sin(half) << ' ' << std::cos(half) << '\n';
}

void write_trajectories(const std::filesystem::path& directory,
                        const std::vector<world::MurpTeamWindow>& windows,
                        const std::vector<world::RelativeEstimateRow>& rows) {
  std::map<PairKey, std::ostringstream> estimates;
  std::map<PairKey, std::ostringstream> truths;
  for (const auto& row : rows) {
    const auto truth = truth_of(windows, row);
    const double time = window_time(windows, row.window);
    auto& e = estimates[{row.base, row.target}];
    auto& t = truths[{row.base, row.target}];
    e << std::setprecision(9);
    t << std::setprecision(9);
    tum_line(e, time, row.estimate.pose);
    if (std::isfinite(truth.heading_rad)) tum_line(t, time, truth);
  }
  const auto trajectories = directory / "trajectories";
  create_output_directories(trajectories);
  for (const auto& [pair, text] : estimates) {
    const std::string stem = "vehicle_" + std::to_string(pair.first) + "_sees_" + std::to_string(pair.second);
    runtime::write_text_file(trajectories / (stem + ".tum"), text.str());
    runtime::write_text_file(trajectories / (stem + "_truth.tum"), truths[pair].str());
  }
}

std::string plot_preamble(const std::string& png) {
  return "set datafile separator ','\nset terminal pngcairo size 900,640 enhanced font ',11'\nset grid\nset "
         "output " +
         gnuplot_quote(png) + "\nset key top left box opaque\n";
}

void write_plots_for(const std::filesystem::path& directory, const world::MurpScore& score,
                     const std::string& title) {
  const auto plots = directory / "plots";
  create_output_directories(plots);
  std::ostringstream time_plot;
  std::ostringstream range_plot;
  time_plot << plot_preamble("error_time.png") << "set title "
            << gnuplot_quote(title + ": position error over time")
            << "\nset xlabel 'time [s]'\nset ylabel 'position error [m]'\nplot ";
  range_plot << plot_preamble("error_range.png") << "set title "
             << gnuplot_quote(title + ": position error against distance")
             << "\nset xlabel 'true distance [m]'\nset ylabel 'position error [m]'\nplot ";
  const char* separator = "";
  for (const auto& [pair, stats] : score.per_pair) {
    const std::string filter =
        "($3==" + std::to_string(pair.first) + " && $4==" + std::to_string(pair.second) + ")";
    time_plot << separator << "'../relative.csv' using 2:(" << filter
              << " ? $18 : 1/0) skip 1 with lines title '" << pair.first << " sees " << pair.second << "'";
    range_plot << separator << "'../relative.csv' using 17:(" << filter
               << " ? $18 : 1/0) skip 1 with points pt 7 ps 0.5 title '" << pair.first << " sees "
               << pair.second << "'";
    separator = ", ";
  }
  runtime::write_text_file(plots / "error_time.gp", time_plot.str() + "\n");
  runtime::write_text_file(plots / "error_range.gp", range_plot.str() + "\n");
  if (score.per_pair.empty()) return;
  for (const char* name : {"error_time", "error_range"}) {
    if (run_gnuplot(plots, std::string(name) + ".gp", {std::string(name) + ".png"}) ==
        GnuplotResult::kNotInstalled) {
      return;
    }
  }
}

}  // namespace

nlohmann::json murp_summary_json(const MurpRunInfo& info, const world::MurpScore& score) {
  nlohmann::json per_pair = nlohmann::json::object();
  for (const auto& [pair, stats] : score.per_pair) per_pair[pair_name(pair)] = stats_json(stats);
  nlohmann::json relative = stats_json(score.pooled);
  relative["truth"] =
      "window poses: the target's pose in the base's level frame recomputed from the two motion-capture "
      "window "
      "poses (not the files' x,y,z columns, which are window averages)";
  relative["per_pair"] = per_pair;
  relative["missing_estimates"] = score.missing_estimates;
  relative["unscored_rows"] = score.unscored_rows;
  return {{"kind", "murp"},
          {"trial", info.trial},
          {"trial_dir", info.trial_dir.string()},
          {"mode", info.mode},
          {"bias", info.bias},
          {"cooperation", info.cooperation},
          {"skipped_windows", info.skipped_windows},
          {"relative", relative},
          {"extra", info.extra}};
}

void write_murp_run_directory(const std::filesystem::path& directory, const MurpRunInfo& info,
                              const std::vector<world::MurpTeamWindow>& windows,
                              const std::vector<world::RelativeEstimateRow>& rows,
                              const world::MurpScore& score) {
  create_output_directories(directory);
  std::error_code ignored;
  std::filesystem::remove(directory / "summary.json", ignored);
  write_relative_csv(directory, windows, rows);
  write_trajectories(directory, windows, rows);
  write_plots_for(directory, score, "MURP trial " + info.trial + " (" + info.mode + ")");
  runtime::write_text_file(directory / "summary.json", murp_summary_json(info, score).dump(2) + "\n");
}

}  // namespace swarmloc::rundir
