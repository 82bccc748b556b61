// `swarmloc-research campaign`: a small seeded simulator campaign end to end (table, CSV, plot script, run
// directories, the loss figures themselves) and spec validation (exit 2 naming the key).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "campaign.hpp"
#include "process_helpers.hpp"

namespace swarmloc::research::campaign_test {
namespace {

using swarmloc::testing::fresh_directory;
using swarmloc::testing::run_command;

const std::string kBinary = SWARMLOC_RESEARCH_BINARY;
const std::string kScenarios = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios";

void write_file(const std::filesystem::path& path, const std::string& text) { std::ofstream(path) << text; }

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::vector<std::map<std::string, std::string>> read_csv(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  std::stringstream head(line);
  for (std::string field; std::getline(head, field, ',');) header.push_back(field);
  std::vector<std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::stringstream row(line);
    for (std::string field; std::getline(row, field, ',');) fields.push_back(field);
    if (line.back() == ',') fields.emplace_back();  // a trailing empty column
    EXPECT_EQ(fields.size(), header.size()) << line;
    std::map<std::string, std::string> named;
    for (std::size_t k = 0; k < header.size() && k < fields.size(); ++k) named[header[k]] = fields[k];
    rows.push_back(named);
  }
  return rows;
}

/// IEIF and Jacobi at 0 and 30 % loss, Bernoulli and bursts, two seeds: 16 short simulator runs.
std::string small_spec() {
  return "name: small\nmode: sim\nseeds: 2\nthreads: 2\n"
         "overrides: {run.steps: 80, world.agents: 20, world.anchors: 6}\n"
         "algorithms:\n"
         "  - {label: IEIF, scenario: " +
         kScenarios +
         "/ieif.yaml}\n"
         "  - {label: Jacobi, scenario: " +
         kScenarios +
         "/jacobi.yaml, overrides: {run.steps: 60}}\n"
         "sweep: {key: network.loss, values: [0, 0.3]}\n"
         "variants:\n"
         "  - {label: bernoulli}\n"
         "  - {label: burst, overrides: {network.burst.mean_length: 5}}\n"
         "check: {value: 0.3, max_ratio: 1.5}\n";
}

TEST(Campaign, SmallSimulatorLossCampaignWritesTableCsvPlotAndStaysWithinOneAndAHalfTimesLossless) {
  const auto dir = fresh_directory("campaign-sim");
  write_file(dir / "spec.yaml", small_spec());
  const auto out = dir / "out";
  const auto result =
      run_command(kBinary + " campaign " + (dir / "spec.yaml").string() + " --out " + out.string() + " -q");
  ASSERT_EQ(result.exit_code, 0) << result.output;

  const auto rows = read_csv(out / "campaign.csv");
  ASSERT_EQ(rows.size(), 16U);             // 2 algorithms × 2 variants × 2 values × 2 seeds
  std::map<std::string, double> rmse_sum;  // "IEIF/bernoulli/0.3" → Σ final RMSE over seeds
  for (const auto& row : rows) {
    EXPECT_EQ(row.at("ok"), "1") << row.at("error");
    EXPECT_EQ(row.at("mode"), "sim");
    const double rmse = std::stod(row.at("final_rmse_m"));
    EXPECT_GT(rmse, 1e-4) << "an RMSE this small at 0.1 m noise means scoring is broken";
    EXPECT_LT(rmse, 1.0);
    rmse_sum[row.at("algorithm") + "/" + row.at("variant") + "/" + row.at("swept_value")] += rmse;
    const double delivered = std::stod(row.at("delivered_fraction"));
    if (row.at("swept_value") == "0") {
      EXPECT_DOUBLE_EQ(delivered, 1.0);
      EXPECT_EQ(row.at("dropped_injected"), "0");
    } else {
      EXPECT_NEAR(delivered, 0.7, 0.06) << "30 % mean loss, Bernoulli or bursts";
    }
    EXPECT_GE(std::stoll(row.at("converge_step")), 0);
    EXPECT_TRUE(std::filesystem::exists(row.at("run_dir") + "/summary.json")) << row.at("run_dir");
    EXPECT_TRUE(std::filesystem::exists(row.at("run_dir") + "/metrics.csv")) << row.at("run_dir");
  }
  for (const std::string algorithm : {"IEIF", "Jacobi"}) {
    for (const std::string variant : {"bernoulli", "burst"}) {
      const double lossless = rmse_sum[algorithm + "/" + variant + "/0"];
      const double lossy = rmse_sum[algorithm + "/" + variant + "/0.3"];
      EXPECT_LE(lossy, 1.5 * lossless) << algorithm << " " << variant;
    }
  }

  const auto markdown = read_file(out / "campaign.md");
  EXPECT_NE(markdown.find("| network.loss | IEIF bernoulli | IEIF burst | Jacobi bernoulli | Jacobi burst |"),
            std::string::npos)
      << markdown;
  EXPECT_NE(markdown.find("\n| 0 | 1.00 [1.00] ("), std::string::npos)
      << "the reference row is 1.00 by definition";
  EXPECT_NE(markdown.find("\n| 0.3 | "), std::string::npos);
  EXPECT_EQ(markdown.find("DDS"), std::string::npos) << "mode sim runs no DDS cell";
  EXPECT_EQ(markdown.find("FAIL"), std::string::npos) << markdown;
  EXPECT_TRUE(std::filesystem::exists(out / "campaign.gp"));
  EXPECT_TRUE(std::filesystem::exists(out / "campaign_plot.dat"));
  EXPECT_NE(read_file(out / "spec.yaml").find("network.burst.mean_length: 5"), std::string::npos);
}

struct BadSpec {
  std::string what;
  std::string spec;
  std::string named;  ///< must appear in the error message
};

// Every shipped spec parses and every one of its cells is a valid scenario (load_campaign_spec loads them).
TEST(Campaign, ShippedSpecsLoadWithEveryCellValid) {
  int specs = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kScenarios + "/campaigns")) {
    if (entry.path().extension() != ".yaml") continue;
    ++specs;
    EXPECT_NO_THROW({
      const CampaignSpec spec = load_campaign_spec(entry.path());
      EXPECT_GE(spec.algorithms.size(), 4U) << entry.path();
      EXPECT_GE(spec.swept_values.size(), 3U) << entry.path();
    }) << entry.path();
  }
  EXPECT_GE(specs, 2) << "loss.yaml and skew.yaml";
}

TEST(Campaign, BadSpecExitsTwoNamingTheKey) {
  const auto dir = fresh_directory("campaign-bad");
  const std::string algorithms = "algorithms: [{label: IEIF, scenario: " + kScenarios + "/ieif.yaml}]\n";
  const std::vector<BadSpec> cases{
      {"unknown top-level key", algorithms + "sweep: {key: network.loss, values: [0]}\nseed: 3\n", "seed"},
      {"misspelt sweep key", algorithms + "sweep: {key: network.loss, valeus: [0]}\n", "sweep.valeus"},
      {"unknown scenario key in overrides",
       algorithms + "overrides: {network.lose: 0.1}\nsweep: {key: network.loss, values: [0]}\n",
       "network.lose"},
      {"swept value out of range", algorithms + "sweep: {key: network.loss, values: [0, 1.4]}\n",
       "network.loss"},
      {"burst shorter than Bernoulli's",
       algorithms + "sweep: {key: network.loss, values: [0.6]}\nvariants: [{label: b, overrides: "
                    "{network.burst.mean_length: 2}}]\n",
       "network.burst.mean_length"},
      {"bad mode", algorithms + "mode: fast\nsweep: {key: network.loss, values: [0]}\n", "mode"},
      {"missing scenario file",
       "algorithms: [{label: X, scenario: no_such.yaml}]\nsweep: {key: network.loss, values: [0]}\n",
       "algorithms[0].scenario"},
  };
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const auto path = dir / ("bad" + std::to_string(k) + ".yaml");
    write_file(path, cases[k].spec);
    const auto result =
        run_command(kBinary + " campaign " + path.string() + " --out " + (dir / "out").string());
    EXPECT_EQ(result.exit_code, 2) << cases[k].what << "\n" << result.output;
    EXPECT_NE(result.output.find(cases[k].named), std::string::npos) << cases[k].what << "\n"
                                                                     << result.output;
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "out" / "campaign.md")) << "nothing runs after a bad spec";
}

TEST(Campaign, ConvergeStepIsWhereTheRmseEntersItsFinalBandForGood) {
  // final 0.1, first 2.0: band = max(0.11, 0.1 + 0.19) = 0.29; 0.3 at step 3 is outside, 0.2 at 4 inside.
  EXPECT_EQ(converge_step({{2.0, 0}, {1.0, 0}, {0.25, 0}, {0.3, 0}, {0.2, 0}, {0.12, 0}, {0.1, 0}}), 4);
  // Unscored agents at the start do not set `first`; steps with missing agents are never converged.
  EXPECT_EQ(converge_step({{0.0, 5}, {1.0, 0}, {0.5, 1}, {0.1, 0}, {0.1, 0}}), 3);
  // A flat run has converged from its first step (band = 1.1 × final).
  EXPECT_EQ(converge_step({{0.1, 0}, {0.105, 0}, {0.1, 0}}), 0);
  // Agents missing at the end: no final value, no convergence.
  EXPECT_EQ(converge_step({{1.0, 0}, {0.1, 2}}), -1);
}

TEST(Campaign, StillFallingFlagsARunWhoseLastTenthIsWellBelowItsSeventhToEighthTenth) {
  auto decaying = [](double per_step, double floor) {  // rmse(k) = floor + per_step^k, 100 steps
    std::vector<RmseSample> steps;
    for (int k = 0; k < 100; ++k) steps.push_back({floor + std::pow(per_step, k), 0});
    return steps;
  };
  // 0.976 per step (the slow Jacobi world of the loss campaign, seed 9): steps 90–99 average
  // 0.976^20 ≈ 0.6 of steps 70–79, still falling. 0.9 per step settled on its floor long before.
  EXPECT_TRUE(still_falling(decaying(0.976, 0.0)));
  EXPECT_FALSE(still_falling(decaying(0.9, 0.01)));
  // A noisy flat run is not falling; a run shorter than 20 steps is never judged.
  std::vector<RmseSample> noisy;
  for (int k = 0; k < 100; ++k) noisy.push_back({k % 2 == 0 ? 0.12 : 0.08, 0});
  EXPECT_FALSE(still_falling(noisy));
  EXPECT_FALSE(still_falling({{1.0, 0}, {0.5, 0}, {0.1, 0}}));
  // Unscored steps are left out of both windows.
  auto gaps = decaying(0.976, 0.0);
  for (int k = 70; k < 80; k += 2) gaps[static_cast<std::size_t>(k)] = {1e9, 3};
  EXPECT_TRUE(still_falling(gaps));
}

}  // namespace
}  // namespace swarmloc::research::campaign_test
