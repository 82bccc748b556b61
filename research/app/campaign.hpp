#pragma once
// `swarmloc campaign SPEC`: sweeps one scenario key over a list of values for several algorithms,
// variants and seeds, in the simulator and/or over DDS, and writes one table (campaign.md), one CSV
// (campaign.csv, a row per run), one plot (campaign.png) and every cell's run directory.
// The spec format is documented in docs/robustness.md ("Loss campaign") and scenarios/campaigns/loss.yaml.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace swarmloc::research {

struct CampaignSpec {
  std::string name = "campaign";
  struct Algorithm {
    std::string label;                   ///< column name, e.g. "IEIF"
    std::filesystem::path scenario;      ///< resolved against the spec file's directory
    std::vector<std::string> overrides;  ///< "key=value", applied after the common overrides
  };
  struct Variant {
    std::string label;  ///< e.g. "bernoulli", "burst"
    std::vector<std::string> overrides;
  };
  std::vector<Algorithm> algorithms;
  std::vector<std::string> overrides;  ///< common to every cell
  std::string swept_key;
  std::vector<std::string> swept_values;  ///< as written in the spec; the first is the reference
  std::vector<Variant> variants;          ///< at least one (a single unnamed "-" if the spec has none)
  std::vector<std::uint64_t> seeds{1};
  std::vector<std::uint64_t> dds_seeds;   ///< empty: the same as seeds
  std::vector<std::string> modes{"sim"};  ///< "sim" and/or "dds", in this order
  /// Optional pass/fail line: final RMSE at swept value `check_value` ≤ check_max_ratio × reference.
  std::optional<std::string> check_value;
  double check_max_ratio = 1.5;
  int threads = 0;  ///< simulator worker threads (0 = every core)
};

/// Parses and validates a campaign spec, and loads every cell's scenario once so that an unknown key
/// or bad value anywhere is found before anything runs. Throws config::ScenarioError naming the key.
CampaignSpec load_campaign_spec(const std::filesystem::path& path);

/// The spec as run (CLI choices applied), as YAML.
std::string campaign_spec_yaml(const CampaignSpec& spec);

/// Time to converge of one run: the first step from which the RMSE stays at or below
/// max(1.1 · final, final + 0.1 · (first − final)) until the end, where `first` is the RMSE of the first
/// step at which every agent was scored and `final` that of the last step. Steps with unscored agents
/// count as not converged. Returns −1 if the last step itself does not qualify (agents missing).
struct RmseSample {
  double rmse_m = 0.0;
  int missing = 0;
};
std::int64_t converge_step(const std::vector<RmseSample>& steps);

/// True if the RMSE is still falling at the end of the run: the mean over the last 10 % of the steps is
/// below 0.8 × the mean over the steps from 70 % to 80 % (steps with unscored agents left out; false for
/// runs shorter than 20 steps). A reference run that is still falling makes a "final RMSE" ratio compare
/// two transients (how far each run got), not two final errors.
bool still_falling(const std::vector<RmseSample>& steps);

struct CampaignOptions {
  std::filesystem::path spec_path;
  std::filesystem::path out_dir;  ///< empty: runs/campaign-<name>-<utc stamp>
  std::string mode;               ///< "", "sim", "dds" or "both" ("" = the spec's)
  int seeds = 0;                  ///< > 0: seeds 1 … K in every mode (instead of the spec's)
  bool progress = true;
  std::string agent_binary;  ///< the swarmloc executable, for DDS cells
};

/// Returns the exit code: 0 ok, 2 bad spec, 1 if any run failed or the campaign was interrupted.
int run_campaign(const CampaignOptions& options);

}  // namespace swarmloc::research
