#include "calibrate_murp.hpp"

#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "swarmloc/rundir/murp_calibration_file.hpp"
#include "swarmloc/world/murp.hpp"

namespace swarmloc::orchestrator {
namespace {

/// printf into a string.
__attribute__((format(printf, 2, 3))) void append(std::string& text, const char* format, ...) {
  char line[512];
  va_list args;
  va_start(args, format);
  std::vsnprintf(line, sizeof line, format, args);
  va_end(args);
  text += line;
}

void append_offsets(std::string& text, const world::MurpRangeCalibration& c) {
  text += "Antenna offsets (m; added to every range the antenna takes part in, as base or target):\n";
  text += "  vehicle      1        2        3        4        5        6\n";
  for (std::size_t v = 0; v < c.antenna_offsets_m.size(); ++v) {
    append(text, "  %zu       ", v + 1);
    for (const double offset : c.antenna_offsets_m[v]) append(text, " %+8.4f", offset);
    text += "\n";
  }
}

void append_coefficients(std::string& text, const world::MurpRangeCalibration& c) {
  const auto& k = c.coefficients_m;
  text +=
      "Bias of the line of sight (m; s = sine of its elevation, f = cosine between an antenna's lever arm "
      "and it):\n";
  append(text, "  %+.4f |s|  %+.4f s^2  %+.4f s  %+.4f (f_base + f_target)  %+.4f (f_base^2 + f_target^2)\n",
         k(0), k(1), k(2), k(3), k(4));
}

void append_spread_bin(std::string& text, const world::MurpRangeCalibration& c,
                       const world::MurpSpreadBin& bin) {
  const double spread_sq = bin.median_spread_m * bin.median_spread_m;
  const double model = std::hypot(c.range_std_m, c.spread_noise_gain * spread_sq);
  char edges[32];
  if (std::isfinite(bin.to_m)) {
    std::snprintf(edges, sizeof edges, "[%4.2f, %4.2f)", bin.from_m, bin.to_m);
  } else {
    std::snprintf(edges, sizeof edges, ">= %4.2f", bin.from_m);
  }
  append(text, "      %-12s  %9zu   %13.3f   %10.4f   %.4f\n", edges, bin.ranges, bin.median_spread_m,
         bin.robust_std_m, model);
}

void append_noise(std::string& text, const world::MurpRangeCalibration& c) {
  append(text,
         "Noise after the bias: sigma0 %.4f m (1.4826 x median |residual|), %zu ranges, %.2f %% beyond %.0f "
         "sigma0\n",
         c.range_std_m, c.ranges_used, 100.0 * c.outlier_fraction, world::kMurpOutlierSigmas);
  append(
      text,
      "  by the spread of the readings averaged into the window; model sqrt(sigma0^2 + (kappa spread^2)^2) "
      "at the\n  bin's median spread, kappa %.3f (least squares of log(robust std / model), "
      "count-weighted):\n",
      c.spread_noise_gain);
  text += "      spread (m)       ranges   median spread   robust std   model std\n";
  for (const auto& bin : c.spread_bins) append_spread_bin(text, c, bin);
}

}  // namespace

world::MurpRangeCalibration measure_murp_ranges(const std::vector<std::string>& dirs) {
  std::vector<world::MurpTrial> trials;
  trials.reserve(dirs.size());
  for (const auto& dir : dirs) trials.push_back(world::load_murp_trial(dir));
  return world::calibrate_murp_ranges(trials);
}

std::string murp_calibration_report(const world::MurpRangeCalibration& c) {
  std::string text = "MURP range model fitted on trials";
  for (const auto& trial : c.trials) text += " " + trial;
  text +=
      "\n  residual = measured range - range between the ring antennas at both vehicles' motion-capture "
      "poses;\n  Huber-weighted ridge least squares over every valid range of every ordered pair "
      "(docs/real-data.md).\n\n";
  append_offsets(text, c);
  append_coefficients(text, c);
  append_noise(text, c);
  return text;
}

int run_calibrate_murp(const std::vector<std::string>& dirs, const std::string& out_path) {
  try {
    const auto calibration = measure_murp_ranges(dirs);
    std::fputs(murp_calibration_report(calibration).c_str(), stdout);
    if (!out_path.empty()) {
      rundir::write_murp_calibration(calibration, out_path);
      std::printf("written to %s\n", out_path.c_str());
    }
    return 0;
  } catch (const std::exception& error) {
    // An unreadable trial or one too thin to fit is bad input, as for --mrclam.
    std::fprintf(stderr, "error: %s\n", error.what());
    return 2;
  }
}

}  // namespace swarmloc::orchestrator
