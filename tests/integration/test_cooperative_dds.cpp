// Atanasov et al., Leng et al., Calafiore et al. as one OS process per agent over Cyclone DDS: Jacobi
// (STATE), DG-BB (STATE + CONSENSUS rounds), multipath BP (BELIEF) and the DLE (INFO + STATE): a short free
// run per family under 20 % injected loss, and lockstep runs equal to the simulator on the same seed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "process_helpers.hpp"

namespace cooperative_dds_test {
namespace {

using swarmloc::testing::count_processes_matching;
using swarmloc::testing::fresh_directory;
using swarmloc::testing::read_json;
using swarmloc::testing::run_command;

const std::string kBinary = SWARMLOC_BINARY;

std::string scenario(const std::string& name) {
  return std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/" + name + ".yaml";
}

nlohmann::json run(const std::string& mode, const std::string& name, const std::string& run_name,
                   const std::string& flags) {
  const auto dir = fresh_directory(run_name);
  const auto result =
      run_command(kBinary + " " + mode + " " + scenario(name) + " -q --out " + dir.string() + flags);
  EXPECT_TRUE(mode == "run" ? swarmloc::testing::completed_run(result.exit_code) : result.exit_code == 0)
      << result.output;
  if (mode == "run") {
    EXPECT_EQ(count_processes_matching(dir.string()), 0) << "agent processes outlived the run";
  }
  return read_json(dir / "summary.json");
}

struct Case {
  const char* scenario;
  int domain;
  const char* flags;            ///< keeps each run around 10 s of world time
  const char* label = nullptr;  ///< the test's name when a scenario runs twice (default: the scenario)
};

std::string case_name(const ::testing::TestParamInfo<Case>& param_info) {
  return param_info.param.label != nullptr ? param_info.param.label : param_info.param.scenario;
}

// One short DDS free run per algorithm family, under 20 % injected loss and 100 ppm of clock drift (so that,
// as between real processes, no two agents step at the same instant). It shows that the family runs as one
// process per agent with free-running clocks and lossy links: every agent is scored, the final error is
// finite and below a bound that sits between a working estimator (4-25x below it, figures below) and a
// broken one (no update or no message used: the initial guess; 2-10x above it), the injected loss is
// counted, and no agent process outlives the run. That DDS computes what the simulator computes is
// LockstepOverDds below (to 1e-9, per family, with loss).
//
// Why no accuracy comparison with the simulator here: this tier used to require each free run within 10 %
// of the simulator's free-run schedule and a 20 %-loss run within 1.5x (275 s of serial runs). A free run's
// error depends on which samples each agent happened to hold when its timer fired, so those bounds were
// statistical, and they were loosened three times after flakes on loaded machines. The bounds below hold
// for any schedule a loaded machine produces: a late or skipped timer tick (agent_node.cpp does not burst to
// catch up) costs a few steps of convergence, and the simulator meets every bound within the first third
// of the run (DG-BB: the first sixth of its rounds).
struct Smoke {
  const char* name;
  const char* scenario;
  int domain;
  const char* flags;
  double max_rmse_m;      ///< the bound on the final location error
  double max_field_rmse;  ///< joint_field only: the bound on the final field error (0: not checked)
  int min_exchanges = 0;  ///< run.agent_steps_per_world_step: the least sends per link and world step
};

// Figures: seed 1, 20 % loss, simulator with agent clocks (sim_clock = agents, the DDS agent's tick phases;
// measured again after run.tick_phase) and one DDS run on a machine at load average 8 (2 cores), 2026-12-02.
// "Broken": the error of the initial guess or of the first step.
const Smoke kSmokes[] = {
    // Jacobi (STATE), with five exchanges per world step on a sparse graph with one reference node
    // (run.agent_steps_per_world_step): sim 0.043 m, DDS 0.035-0.047 m at 50 steps; one exchange per world
    // step 0.41 m; no message used 2.9 m (initial guess). DDS sent 6.0 samples per link and world step; one
    // exchange sends 1.0-1.2, so more than 2 shows that the extra exchanges ran. Jacobi at one exchange per
    // step: LockstepOverDds/jacobi.
    {"jacobi_five_steps_per_world_step", "jacobi", 32,
     " --set world.agents=40 --set world.anchors=1 --set world.area_m=80 --set world.comm_radius_m=20"
     " --set run.steps=50 --set run.rate_hz=10 --set run.agent_steps_per_world_step=5",
     0.3, 0.0, 2},
    // DG-BB (STATE + CONSENSUS rounds), 5 x 5 lattice on 1 m: sim 0.0037 m at 300 steps, DDS 0.0038 m; the
    // initial guess 0.057 m. The sim is below 0.015 m from step 50: DDS may lose 5/6 of its rounds.
    {"dgbb", "dgbb", 33, " --set run.steps=300", 0.015, 0.0},
    // Multipath BP (BELIEF): sim 0.314 m, DDS 0.32 m, flat from step 5 (angle errors dominate); first step
    // 1.19 m, initial guess 2.8 m.
    {"multipath_bp", "multipath_bp", 35, " --set run.steps=30", 1.0, 0.0},
    // Static DLE (INFO + STATE consensus): sim 0.018 m, DDS 0.027 m at 40 steps; one reading 1.0 m; a sensor
    // that only averages its own 40 readings 0.22 m.
    {"dle", "dle", 56, " --set run.rate_hz=20 --set run.steps=40", 0.15, 0.0},
    // Tracking DLE: sim 0.071 m, DDS 0.041 m at 50 steps; the first step 11 m (the prior
    // is the area's centre).
    {"dle_tracking", "dle_tracking", 60, " --set run.steps=50", 1.0, 0.0},
    // Joint field: positions sim 0.0075 m, DDS 0.0075 m (initial guess 2.8 m); field sim 0.20, DDS 0.20 at
    // 60 steps, 1.25 before any reading (the field is learnt slowly: half of that is the bound).
    {"joint_field", "joint_field", 34, " --set run.steps=60", 0.1, 0.625},
};

/// agents.csv: agent,anchor,steps_run,samples_published,cpu_s,exit_code,... — the agents with steps_run > 0
/// and exit code 0.
int agents_that_ran_and_exited_cleanly(const std::filesystem::path& dir) {
  std::ifstream in(dir / "agents.csv");
  std::string line;
  std::getline(in, line);
  int clean = 0;
  while (std::getline(in, line)) {
    std::stringstream fields(line);
    std::vector<std::string> cells;
    for (std::string cell; std::getline(fields, cell, ',');) cells.push_back(cell);
    if (cells.size() > 5 && std::stoll(cells[2]) > 0 && cells[5] == "0") ++clean;
  }
  return clean;
}

std::string smoke_name(const ::testing::TestParamInfo<Smoke>& param_info) { return param_info.param.name; }

class FreeRunOverDds : public ::testing::TestWithParam<Smoke> {};

TEST_P(FreeRunOverDds, EveryAgentRunsTheErrorIsBelowABrokenEstimatorsAndTheLossIsCounted) {
  const Smoke c = GetParam();
  const auto dds =
      run("run", c.scenario, std::string(c.name) + "-free-run-dds",
          std::string(c.flags) + " --set clock.drift_ppm=100 --set network.loss=0.2 --set dds.domain_id=" +
              std::to_string(c.domain));
  ASSERT_TRUE(dds.contains("final")) << c.name;
  const auto& end = dds["final"];
  const int agents = dds["agents"];
  const int anchors = dds["anchors"];
  // Every agent process ran and exited cleanly (agents.csv). Not "every agent scored at the final step":
  // on a loaded machine an agent whose report is a few periods late is unscored at that step (a run-health
  // verdict, not an estimator's), which once turned a green run red.
  EXPECT_EQ(agents_that_ran_and_exited_cleanly(dds["run_directory"].get<std::string>()), agents) << c.name;
  EXPECT_GE(end["scored_agents"].get<int>(), 1) << c.name;
  EXPECT_LE(end["scored_agents"].get<int>(), agents - anchors) << c.name;
  const double rmse = end["rmse_m"];
  EXPECT_TRUE(std::isfinite(rmse)) << c.name;
  EXPECT_LT(rmse, c.max_rmse_m) << c.name;
  if (c.max_field_rmse > 0.0) {
    const double field = end["field_rmse"];
    EXPECT_TRUE(std::isfinite(field)) << c.name;
    EXPECT_LT(field, c.max_field_rmse) << c.name;
  }
  const auto& links = dds["links"];
  EXPECT_GT(links["dropped_injected"].get<double>(), 0.1 * links["arrived"].get<double>()) << c.name;
  if (c.min_exchanges > 0) {
    const double per_link_and_step =
        links["sent"].get<double>() /
        (dds["agents"].get<double>() * dds["mean_degree"].get<double>() * dds["steps"].get<double>());
    EXPECT_GT(per_link_and_step, c.min_exchanges) << c.name;
  }
  std::printf("[ dds ] %s free run, 20 %% loss: final RMSE %.4g m (bound %.3g m)\n", c.name, rmse,
              c.max_rmse_m);
}

INSTANTIATE_TEST_SUITE_P(EveryFamily, FreeRunOverDds, ::testing::ValuesIn(kSmokes), smoke_name);

}  // namespace

namespace {

// run.mode = lockstep: the orchestrator sends world step k's batches once every agent has reported
// step k − 1 done (after its samples were acknowledged), and agents use only samples of earlier steps.
// Sample numbers, hence the seeded loss decisions, match the simulator's, so the runs are identical.
class LockstepOverDds : public ::testing::TestWithParam<Case> {};

TEST_P(LockstepOverDds, FinalErrorsEqualTheSimulatorsToOneInABillion) {
  const Case c = GetParam();
  const std::string flags = std::string(c.flags) + " --set run.mode=lockstep";
  const std::string name = case_name({c, 0});
  const auto sim = run("sim", c.scenario, name + "-lockstep-sim", flags);
  const auto dds = run("run", c.scenario, name + "-lockstep-dds",
                       flags + " --set dds.domain_id=" + std::to_string(c.domain));
  for (const char* key : {"rmse_m", "mean_error_m", "max_error_m", "field_rmse"}) {
    if (!sim["final"].contains(key)) continue;
    const double expected = sim["final"][key];
    EXPECT_NEAR(dds["final"][key].get<double>(), expected, 1e-9 * std::max(1e-3, expected))
        << name << ' ' << key;
  }
  EXPECT_EQ(dds["links"]["dropped_injected"], sim["links"]["dropped_injected"]);
  EXPECT_EQ(dds["lockstep_timeouts"], 0);
}

INSTANTIATE_TEST_SUITE_P(
    EveryRuntimeAlgorithm, LockstepOverDds,
    ::testing::Values(Case{"ieif", 37, " --set run.steps=60 --set network.loss=0.2"},
                      Case{"default", 79, " --set run.steps=60 --set network.loss=0.2", "dml"},
                      // dml_track (docs/algorithms.md §9.8) on the moving world with noisy beacon fixes, in
                      // trial 2's world (its guesses, motion, draws and loss: `--trial`).
                      Case{"ea2", 89,
                           " --set run.steps=30 --set network.loss=0.2 --set algorithm.name=dml_track"
                           " --trial 2",
                           "dml_track"},
                      // A 3-D world (docs/design.md §3.1): positions and covariances carry their z.
                      Case{"default3d", 81, " --set run.steps=60 --set network.loss=0.2", "dml_3d"},
                      Case{"jacobi", 38, " --set run.steps=60 --set network.loss=0.2"},
                      Case{"dgbb", 39, " --set run.steps=150"},
                      Case{"multipath_bp", 40, " --set run.steps=30 --set network.loss=0.2"},
                      Case{"dle", 57, " --set run.steps=40 --set network.loss=0.2"},
                      Case{"dle_tracking", 58, " --set run.steps=60 --set network.loss=0.2"},
                      Case{"joint_field", 68, " --set run.steps=40 --set network.loss=0.2"},
                      // algorithm.bp_messages=exact (not in Leng et al.): each BELIEF lists the messages its
                      // sender summed. Its free run is not in CI (26 s): 2026-12-01, seed 1, DDS 0.36103 m =
                      // the simulator's free run, and 0.36103 m with 20 % loss (cavity messages reach the
                      // same fixed point, later).
                      Case{"multipath_bp", 76,
                           " --set run.steps=30 --set network.loss=0.2 --set algorithm.bp_messages=exact",
                           "multipath_bp_exact"}),
    case_name);

}  // namespace
}  // namespace cooperative_dds_test
