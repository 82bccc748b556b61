// Leng et al. (cooperative multipath localization by belief propagation): Figs. 2–3.
#include <algorithm>
#include <cmath>
#include <sstream>

#include "reproduce_common.hpp"
#include "swarmloc/research/multipath_localization.hpp"

namespace swarmloc::research::reproduce_detail {
namespace {

namespace ex = research;

/// |x error| statistics of one Leng et al. run, pooled over the nodes the paper's Fig. 2 claims are about.
struct MultipathSummary {
  double far_bp_below_2m = 0.0;  ///< BP, S3/S4
  double all_bp_below_3m = 0.0;  ///< BP, S1–S4
  std::size_t bp_above_3m = 0;   ///< BP, S1–S4: how many node-trials
  double bp_largest = 0.0;       ///< BP, S1–S4, largest |x error|
  double far_bp_median = 0.0;
  double far_pairwise_median = 0.0;
  double near_pairwise_median = 0.0;
  double all_central_below_3m = 0.0;  ///< centralized WLS, S1–S4
  std::size_t central_above_3m = 0;
};

MultipathSummary summarize_multipath(const ex::MultipathExperimentResult& r) {
  auto pool = [](const std::vector<std::vector<double>>& per_node, int first, int last) {
    std::vector<double> pooled;
    for (int node = first; node <= last; ++node) {
      const auto& v = per_node[static_cast<std::size_t>(node)];
      pooled.insert(pooled.end(), v.begin(), v.end());
    }
    return pooled;
  };
  auto count_at_least = [](const std::vector<double>& v, double limit) {
    return static_cast<std::size_t>(
        std::count_if(v.begin(), v.end(), [&](double e) { return std::abs(e) >= limit; }));
  };
  auto fraction_below = [&](const std::vector<double>& v, double limit) {
    return v.empty() ? 0.0
                     : 1.0 - static_cast<double>(count_at_least(v, limit)) / static_cast<double>(v.size());
  };
  const auto far_bp = pool(r.bp_x_error, 3, 4);
  const auto all_bp = pool(r.bp_x_error, 1, 4);
  const auto all_central = pool(r.centralized_x_error, 1, 4);
  MultipathSummary summary;
  summary.far_bp_below_2m = fraction_below(far_bp, 2.0);
  summary.all_bp_below_3m = fraction_below(all_bp, 3.0);
  summary.bp_above_3m = count_at_least(all_bp, 3.0);
  summary.bp_largest = ex::abs_quantile(all_bp, 1.0);
  summary.far_bp_median = ex::abs_quantile(far_bp, 0.5);
  summary.far_pairwise_median = ex::abs_quantile(pool(r.pairwise_x_error, 3, 4), 0.5);
  summary.near_pairwise_median = ex::abs_quantile(pool(r.pairwise_x_error, 1, 2), 0.5);
  summary.all_central_below_3m = fraction_below(all_central, 3.0);
  summary.central_above_3m = count_at_least(all_central, 3.0);
  return summary;
}

/// One row of the main table: the walls, the range noise and the message rules of one configuration.
struct MultipathSetup {
  std::vector<double> walls;
  double range_std;
  const char* label;
  bool doa_aware = false;                     // not in Leng et al.: paths weighted by their angle errors too
  bool exact_messages = false;                // not in Leng et al.: exact GaBP (cavity messages)
  bool lengths_from_measured_angles = false;  // the other reading of how Leng et al. drew its lengths
};

/// Leng et al.'s configuration as printed, and the readings and variants not in it.
std::vector<MultipathSetup> multipath_setups() {
  return {{{0.0, 45.0}, 3.0, "0°, 45°"},
          {{0.0, 45.0}, std::sqrt(3.0), "0°, 45°"},
          {{10.0, 20.0, 30.0}, 3.0, "10°, 20°, 30°"},
          {{0.0, 45.0}, 3.0, "0°, 45°, angle-aware (not in Leng et al.)", true},
          {{0.0, 45.0}, std::sqrt(3.0), "0°, 45°, angle-aware (not in Leng et al.)", true},
          {{10.0, 20.0, 30.0}, 3.0, "10°, 20°, 30°, angle-aware (not in Leng et al.)", true},
          {{0.0, 45.0}, 3.0, "0°, 45°, exact GaBP (not in Leng et al.)", false, true},
          {{0.0, 45.0}, std::sqrt(3.0), "0°, 45°, exact GaBP (not in Leng et al.)", false, true},
          {{0.0, 45.0}, std::sqrt(3.0), "0°, 45°, angle-aware exact GaBP (not in Leng et al.)", true, true},
          {{0.0, 45.0}, 3.0, "0°, 45°, lengths from eq. (1) at the measured angles", false, false, true},
          {{0.0, 45.0},
           std::sqrt(3.0),
           "0°, 45°, lengths from eq. (1) at the measured angles",
           false,
           false,
           true}};
}

void multipath_main_table(std::ostringstream& md, int trials, const ReproduceOptions& options) {
  md << "# Leng et al. Figs. 2–3 — cooperative multipath BP vs pairwise localization\n\n"
     << "5 nodes in 10 m × 10 m, S_0 anchor at the origin, links S1–S0, S2–S0, S3–S1, S4–S2, S3–S4, one "
        "reflection per wall, walls 5 m beyond the square's circumscribed circle, DOA error U(±5°) at each "
        "end, 50 BP iterations, seed "
     << options.seed
     << ". Paper (Fig. 2): cooperative > 90 % of |x errors| below 2 m and all below 3 m; pairwise S3, S4 "
        "markedly worse than S1, S2.\n\n"
     << "| walls | range noise | trials | BP S3/S4 < 2 m | BP all < 3 m | BP p50 S3/S4 [m] | pairwise p50 "
        "S3/S4 [m] | pairwise p50 S1/S2 [m] | centralized all < 3 m | Thm. 1 violations |\n"
        "|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& setup : multipath_setups()) {
    ex::MultipathExperimentConfig config;
    config.trials = trials;
    config.seed = options.seed;
    config.wall_angles_deg = setup.walls;
    config.range_std_m = setup.range_std;
    config.doa_aware_paths = setup.doa_aware;
    config.exact_messages = setup.exact_messages;
    config.lengths_from_measured_angles = setup.lengths_from_measured_angles;
    const auto r = ex::run_multipath_experiment(config);
    const auto summary = summarize_multipath(r);
    md << "| " << setup.label << " | std " << fmt("%.2f", setup.range_std) << " m | " << config.trials
       << " | " << fmt("%.1f %%", 100.0 * summary.far_bp_below_2m) << " | "
       << fmt("%.2f %%", 100.0 * summary.all_bp_below_3m) << " | " << fmt("%.2f", summary.far_bp_median)
       << " | " << fmt("%.2f", summary.far_pairwise_median) << " | "
       << fmt("%.2f", summary.near_pairwise_median) << " | "
       << fmt("%.2f %%", 100.0 * summary.all_central_below_3m) << " | " << r.covariance_increase_trials
       << " |\n";
  }
  md << "\n|x error| of nodes S1–S4 after 50 iterations; 'Thm. 1 violations' counts trials in which some "
        "belief's covariance grew between iterations (Thm. 1 is about Leng et al.'s form; exact GaBP is not "
        "covered by it). The angle-aware rows (not in Leng et al.; `algorithm.path_variance=with_doa` in "
        "the runtime) give each path the variance σ² + σ_θ²(‖g‖² − 1)d²/2 of its length and angle errors "
        "(σ_θ² = 5²/3 deg²) instead of σ²; same seed, geometry and noise. The exact GaBP rows (not in Leng "
        "et al., the [D-4] ablation; `algorithm.bp_messages=exact`) divide each node's own contribution out "
        "of the belief it receives. 'centralized' is weighted least squares on all five links' paths at "
        "once (not in Leng et al.), which exact GaBP's means converge to. Every row but the last two draws "
        "a path's length by the image method (docs/algorithms.md §5.4), so the angle errors also make eq. "
        "(1) wrong; the last two read Leng et al.'s Sec. 4 as drawing each length from eq. (1) itself at "
        "the measured angles, g(θ̃_ij, θ̃_ji)ᵀ(s_i − s_j) plus the range noise — the model its Thm. 2 "
        "(unbiased means) takes as exact — so the angle errors enter only through G. With two walls "
        "pairwise is unchanged (two paths, two unknowns).\n";
}

// Where the walls stand is not in Leng et al. ([D-6]); the angle errors' effect grows as the rays to a far
// wall become parallel, so the figure's numbers depend on it.
void multipath_wall_distance_table(std::ostringstream& md, int trials, const ReproduceOptions& options) {
  md << "\n## Wall distance (not given by Leng et al.)\n\n"
     << "Walls 0° and 45°, Leng et al.'s BP as printed, " << trials
     << " trials per row; the margin is the distance between a wall and the square's circumscribed circle "
        "(0 m: the walls touch it).\n\n"
     << "| margin [m] | range noise | BP S3/S4 < 2 m | BP all < 3 m | BP above 3 m | BP largest [m] | "
        "centralized all < 3 m | centralized above 3 m |\n|---|---|---|---|---|---|---|---|\n";
  for (const double margin : {0.0, 2.0, 5.0, 10.0, 20.0}) {
    for (const double range_std : {3.0, std::sqrt(3.0)}) {
      ex::MultipathExperimentConfig config;
      config.trials = trials;
      config.seed = options.seed;
      config.range_std_m = range_std;
      config.wall_margin_m = margin;
      const auto summary = summarize_multipath(ex::run_multipath_experiment(config));
      md << "| " << fmt("%.0f", margin) << " | std " << fmt("%.2f", range_std) << " m | "
         << fmt("%.1f %%", 100.0 * summary.far_bp_below_2m) << " | "
         << fmt("%.2f %%", 100.0 * summary.all_bp_below_3m) << " | " << summary.bp_above_3m << " of "
         << 4 * trials << " | " << fmt("%.2f", summary.bp_largest) << " | "
         << fmt("%.2f %%", 100.0 * summary.all_central_below_3m) << " | " << summary.central_above_3m
         << " |\n";
    }
  }
}

// Which error makes the tail, and how the other reading of the lengths changes it; same seed (every
// draw is made in every row).
void multipath_error_sources_table(std::ostringstream& md, int trials, const ReproduceOptions& options) {
  md << "\n## Where the errors above 3 m come from\n\n"
     << "Walls 0° and 45° at the 5 m margin, " << trials
     << " trials per row, Leng et al.'s BP as printed and the centralized least squares on the same draws. "
        "'image': lengths by the image method (§5.4); 'eq. (1)': lengths from eq. (1) at the measured "
        "angles.\n\n"
     << "| range noise | DOA error | lengths | BP S3/S4 < 2 m | BP all < 3 m | BP above 3 m | BP largest [m] "
        "| centralized above 3 m |\n|---|---|---|---|---|---|---|---|\n";
  struct Source {
    double doa_deg;
    bool lengths_from_measured_angles;
  };
  for (const double range_std : {3.0, std::sqrt(3.0)}) {
    for (const Source source : {Source{5.0, false}, Source{0.0, false}, Source{5.0, true}}) {
      ex::MultipathExperimentConfig config;
      config.trials = trials;
      config.seed = options.seed;
      config.range_std_m = range_std;
      config.doa_error_deg = source.doa_deg;
      config.lengths_from_measured_angles = source.lengths_from_measured_angles;
      const auto summary = summarize_multipath(ex::run_multipath_experiment(config));
      md << "| std " << fmt("%.2f", range_std) << " m | " << (source.doa_deg > 0.0 ? "U(±5°)" : "none")
         << " | " << (source.lengths_from_measured_angles ? "eq. (1)" : "image") << " | "
         << fmt("%.1f %%", 100.0 * summary.far_bp_below_2m) << " | "
         << fmt("%.2f %%", 100.0 * summary.all_bp_below_3m) << " | " << summary.bp_above_3m << " of "
         << 4 * trials << " | " << fmt("%.2f", summary.bp_largest) << " | " << summary.central_above_3m
         << " |\n";
    }
  }
  md << "\nWith exact angles the centralized solution is the efficient estimator of eq. (1), so what remains "
        "above 3 m there is the length noise's own tail; the rest of the tail in the image rows is what the "
        "angle errors do to eq. (1).\n";
}

}  // namespace

int reproduce_multipath(const ReproduceOptions& options) {
  const int trials = options.trials > 0 ? options.trials : 1000;
  std::ostringstream md;
  multipath_main_table(md, trials, options);
  multipath_wall_distance_table(md, trials, options);
  multipath_error_sources_table(md, trials, options);
  emit(options.out_dir, "multipath_003", md.str());
  return 0;
}

}  // namespace swarmloc::research::reproduce_detail
