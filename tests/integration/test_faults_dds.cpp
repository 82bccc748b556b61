// Scheduled faults over DDS with real processes: kill -9 and restart, SIGSTOP/SIGCONT, a partition —
// scored against truth by the orchestrator, and no process left behind.
#include <gtest/gtest.h>

#include <fstream>
#include <set>
#include <sstream>

#include "process_helpers.hpp"

namespace faults_dds_test {
namespace {

using swarmloc::testing::count_processes_matching;
using swarmloc::testing::fresh_directory;
using swarmloc::testing::read_json;
using swarmloc::testing::run_command;

const std::string kBinary = SWARMLOC_BINARY;
const std::string kScenario = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/ieif.yaml";

struct StepRow {
  double rmse_m = 0.0;
  int scored = 0;
};

/// metrics.csv: step,time_s,rmse_m,mean_error_m,max_error_m,crlb_rmse_m,nees,scored,missing
std::vector<StepRow> read_metrics(const std::filesystem::path& dir) {
  std::ifstream in(dir / "metrics.csv");
  std::string line;
  std::getline(in, line);
  std::vector<StepRow> rows;
  while (std::getline(in, line)) {
    std::stringstream fields(line);
    std::string cell;
    std::vector<std::string> cells;
    while (std::getline(fields, cell, ',')) cells.push_back(cell);
    if (cells.size() < 8) continue;
    rows.push_back({std::stod(cells[2]), std::stoi(cells[7])});
  }
  return rows;
}

/// The agents with at least one valid estimates.csv row at or after `from_step`.
std::set<int> agents_reporting_from(const std::filesystem::path& dir, int from_step) {
  std::ifstream in(dir / "estimates.csv");
  std::string line;
  std::getline(in, line);  // step,agent,x_m,y_m,cov_xx,cov_xy,cov_yy,valid,...
  std::set<int> agents;
  while (std::getline(in, line)) {
    std::stringstream fields(line);
    std::string cell;
    std::vector<std::string> cells;
    while (std::getline(fields, cell, ',')) cells.push_back(cell);
    if (cells.size() < 8 || std::stoi(cells[0]) < from_step || cells[7] != "1") continue;
    agents.insert(std::stoi(cells[1]));
  }
  return agents;
}

std::filesystem::path run_dds(const std::string& name, const std::string& flags, int domain) {
  const auto dir = fresh_directory(name);
  const auto result =
      run_command(kBinary + " run " + kScenario + " -q --out " + dir.string() +
                  " --set run.steps=140 --set dds.domain_id=" + std::to_string(domain) + flags);
  EXPECT_TRUE(swarmloc::testing::completed_run(result.exit_code)) << result.output;
  EXPECT_EQ(count_processes_matching(dir.string()), 0) << "agent processes outlived the run";
  return dir;
}

TEST(FaultsOverDds, KilledAgentsLeaveTheOthersUnharmedAndRestartedOnesRecoverWithinThirtySteps) {
  // 6 of 30 agents (20 %) are killed with SIGKILL at step 60 and restarted at 100; agent 7 is paused.
  // The no-fault reference is the same run before the fault, not a second run: free-run runs of one
  // seed differ by up to 2x over a window (process timing decides which batches and neighbour states
  // each step sees), so a 1.5x bound against another run would test the scheduler. The pre-fault level
  // is the stricter reference: the error still falls after step 60 in a clean run
  // (docs/measurements/free-run-spread.md §1.3).
  const auto dir = run_dds("faults-kill",
                           " --set faults.kill=1@60-100,2@60-100,3@60-100,4@60-100,5@60-100,6@60-100"
                           " --set faults.pause=7@60-80",
                           52);
  const auto faulty = read_metrics(dir);
  ASSERT_EQ(faulty.size(), 140U);
  EXPECT_LT(faulty[70].scored, 22) << "dead and paused agents are not scored";
  auto window_mean = [](const std::vector<StepRow>& rows, std::size_t from, std::size_t to) {
    double sum = 0.0;
    for (std::size_t step = from; step < to; ++step) sum += rows[step].rmse_m;
    return sum / static_cast<double>(to - from);
  };
  const double before = window_mean(faulty, 50, 60);
  const double during = window_mean(faulty, 62, 100);
  // Free-run levels before the fault spread several-fold between runs (docs/measurements/free-run-spread.md
  // §1.3): this bound catches a broken estimator (metres), not that spread; the ratios below carry the test.
  EXPECT_LT(before, 0.5) << "the run had not diverged before the fault";
  EXPECT_LT(during, 1.5 * before) << "the living, steps 62-99, vs steps 50-59 of the same run";
  // Per agent, not one step's count: a free-run estimate can miss a single step's scoring (CI once saw
  // 21 of 22 at step 130), but a restarted agent that never reports again cannot hide in a window.
  const auto reporting = agents_reporting_from(dir, 110);
  for (int agent = 1; agent <= 7; ++agent) EXPECT_TRUE(reporting.contains(agent)) << "agent " << agent;
  // A restarted agent that does not recover stays near its 2 m starting guess; recovered runs end at
  // centimetres. The mean over the last ten steps carries no single step's timing.
  EXPECT_LT(window_mean(faulty, 130, 140), std::max(0.5, 3.0 * before)) << "30 steps after the restart";
  const auto summary = read_json(dir / "summary.json");
  EXPECT_EQ(summary["processes"], 37) << "30 agents + 6 restarts + the orchestrator";
  EXPECT_LT(summary["links"]["sent"].get<double>(), 1e6) << "sent spans restarts";
  EXPECT_TRUE(std::filesystem::exists(dir / "logs" / "agent_001.restart1.log"));
}

TEST(FaultsOverDds, BothSidesOfAPartitionKeepEstimatingAndTheErrorHeals) {
  const auto dir = run_dds("faults-partition", " --set faults.partition=60-79", 53);
  const auto parted = read_metrics(dir);
  ASSERT_EQ(parted.size(), 140U);
  for (std::size_t step = 60; step < 80; ++step) EXPECT_EQ(parted[step].scored, 22) << step;
  EXPECT_LT(parted[110].rmse_m, 1.2 * parted[59].rmse_m) << "30 steps after the heal";
  const auto summary = read_json(dir / "summary.json");
  EXPECT_GT(summary["links"]["dropped_injected"].get<double>(), 0.0);
}

}  // namespace
}  // namespace faults_dds_test
