// swarmloc-research — the papers' experiments and parameter campaigns, kept out of the product binary
// (docs/architecture.md). Exit codes: 0 ok, 2 bad input (experiment, spec, flags), 1 runtime failure.
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <array>
#include <cerrno>
#include <climits>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "campaign.hpp"
#include "cli_support.hpp"
#include "reproduce.hpp"

namespace {

/// The product CLI, `swarmloc`, installed beside this binary: campaigns run its `run` and its agents.
std::string product_executable(const char* argv0) {
  return (swarmloc::orchestrator::self_executable(argv0).parent_path() / "swarmloc").string();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "swarmloc-research: the papers' experiments and parameter campaigns.\n\n"
      "  swarmloc-research reproduce ieif-table1            # a paper table beside the paper's numbers\n"
      "  swarmloc-research campaign scenarios/campaigns/loss.yaml --mode sim   # loss sweep\n",
      "swarmloc-research"};
  app.require_subcommand(1);
  app.footer("Exit codes: 0 ok, 2 bad input (experiment, spec or flags), 1 runtime failure or interrupted.");

  auto* reproduce = app.add_subcommand(
      "reproduce", "Run a paper experiment; writes a Markdown table beside the paper's numbers.");
  swarmloc::research::ReproduceOptions reproduce_options;
  std::string reproduce_out = "runs/reproduce";
  std::string experiments_help;
  for (const auto& name : swarmloc::research::known_experiments())
    experiments_help += (experiments_help.empty() ? "" : " | ") + name;
  reproduce->add_option("experiment", reproduce_options.experiment, experiments_help)
      ->required()
      ->check(CLI::IsMember(swarmloc::research::known_experiments()));
  reproduce->add_option("--out", reproduce_out, "Output directory (default runs/reproduce)");
  reproduce
      ->add_option("--trials", reproduce_options.trials, "Monte Carlo trials (default: the paper's count)")
      ->check(swarmloc::orchestrator::kPositiveInteger);
  reproduce->add_option("--threads", reproduce_options.threads, "Worker threads (default: every core)")
      ->check(CLI::NonNegativeNumber);
  reproduce->add_option("--seed", reproduce_options.seed, "Seed");

  auto* campaign = app.add_subcommand(
      "campaign",
      "Sweep one scenario key (e.g. network.loss) over algorithms, variants and seeds, in the simulator "
      "and/or over DDS; writes campaign.md, campaign.csv and campaign.png (docs/robustness.md).");
  swarmloc::research::CampaignOptions campaign_options;
  campaign
      ->add_option("spec", campaign_options.spec_path,
                   "Campaign spec YAML (e.g. scenarios/campaigns/loss.yaml)")
      ->required();
  campaign->add_option("--out", campaign_options.out_dir,
                       "Campaign directory (default: runs/campaign-<name>-<stamp>)");
  campaign->add_option("--mode", campaign_options.mode, "sim | dds | both (default: the spec's mode)")
      ->check(CLI::IsMember({"sim", "dds", "both"}));
  campaign
      ->add_option("--seeds", campaign_options.seeds, "Run seeds 1..K in every mode (default: the spec's)")
      ->check(CLI::Range(1, 1000));
  bool campaign_quiet = false;
  campaign->add_flag("-q,--quiet", campaign_quiet, "No line per finished run");

  std::signal(SIGXFSZ, SIG_IGN);  // a file size limit fails a write with EFBIG instead of killing us
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return 2;
  }
  spdlog::set_pattern("%H:%M:%S.%e %^%l%$ %v");
  if (campaign->parsed()) {
    campaign_options.progress = !campaign_quiet;
    campaign_options.agent_binary = product_executable(argv[0]);
    return swarmloc::research::run_campaign(campaign_options);
  }
  reproduce_options.out_dir = reproduce_out;
  return swarmloc::research::run_reproduce(reproduce_options);
}
