// Papers 002, 003, 004 as one OS process per agent over Cyclone DDS: Jacobi (STATE), DG-BB (STATE +
// CONSENSUS rounds), multipath BP (BELIEF) and the DLE (INFO + STATE), each against the simulator on the
// same seed, and under 20 % injected loss.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "process_helpers.hpp"

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

// A DDS free run is compared with the simulator's free-run schedule (run.sim_clock = agents: each agent
// steps on its own clock, on the newest batch and samples), both with 100 ppm of clock drift so that, as
// between real processes, no two agents step at the same instant. Synchronous rounds differ from a free run
// by their schedule alone, most for the DLE: a sensor that steps after a neighbour within a period mixes that
// neighbour's update of the same world step, and agents sometimes step without a fresh batch and keep mixing.
// Against rounds (docs/reproduction.md) the tracking DLE's DDS error is 27–31 % lower and the static DLE's
// 3 % lower at 200 steps (11 % at 100); every other algorithm's location error is within 3 % of either
// schedule.
constexpr const char* kFreeRun = " --set clock.drift_ppm=100";
constexpr const char* kSimulatorFreeRun = " --set run.sim_clock=agents";
// The static DLE's error is one 2-D realization shared by every sensor, and each sensor over-weights its own
// newest reading (weight 1/(t+1) instead of 1/(N(t+1))); at 200 steps that term is small.
constexpr const char* kDleFlags = " --set run.rate_hz=20 --set run.steps=200";
// run.agent_steps_per_world_step: five exchanges per measurement on a sparse graph with one reference node,
// where they matter (seed 1, 100 steps, agent clocks in the simulator: 0.0296 m; with one step per world
// step 0.158 m, and 30 steps give 0.0297 m: five reach the fixed point).
constexpr const char* kFiveStepsPerWorldStep =
    " --set world.agents=40 --set world.anchors=1 --set world.area_m=80 --set world.comm_radius_m=20"
    " --set run.steps=100 --set run.rate_hz=10 --set run.agent_steps_per_world_step=5";

class CooperativeOverDds : public ::testing::TestWithParam<Case> {};

TEST_P(CooperativeOverDds, FinalErrorMatchesTheSimulatorWithinTenPercentAndSurvivesTwentyPercentLoss) {
  const Case c = GetParam();
  const std::string domain = " --set dds.domain_id=" + std::to_string(c.domain);
  const std::string flags = std::string(c.flags) + kFreeRun;
  const std::string name = case_name({c, 0});
  const auto sim = run("sim", c.scenario, name + "-sim", flags + kSimulatorFreeRun);
  const auto dds = run("run", c.scenario, name + "-dds", flags + domain);
  const double sim_rmse = sim["final"]["rmse_m"];
  const double dds_rmse = dds["final"]["rmse_m"];
  EXPECT_EQ(dds["final"]["scored_agents"], sim["final"]["scored_agents"]);
  EXPECT_NEAR(dds_rmse, sim_rmse, 0.10 * sim_rmse) << name << ": DDS " << dds_rmse << " vs sim " << sim_rmse;
  EXPECT_EQ(dds["links"]["dropped_injected"], 0);
  if (sim["final"].contains("field_rmse")) {
    // joint_field's field error (scenario with algorithm.field_warmup_steps = 10): sim free run 0.1505, DDS
    // 0.1392 (−7.5 %; rounds 0.1509; without drift DDS was 0.138–0.144 in three runs): the free run keeps
    // mixing without fresh readings, as for the DLE.
    // Without the warm-up the early readings, modelled at positions still in their transient, made it +4 to
    // +22 %, depending on the timing of the first steps.
    const double sim_field = sim["final"]["field_rmse"];
    EXPECT_NEAR(dds["final"]["field_rmse"].get<double>(), sim_field, 0.15 * sim_field);
    std::printf("[ dds ] %s: final field RMSE sim %.4g, DDS %.4g\n", c.scenario, sim_field,
                dds["final"]["field_rmse"].get<double>());
  }

  const std::string lossy_domain = " --set dds.domain_id=" + std::to_string(c.domain + 1);
  const auto lossy =
      run("run", c.scenario, name + "-dds-loss", flags + lossy_domain + " --set network.loss=0.2");
  const double lossy_rmse = lossy["final"]["rmse_m"];
  EXPECT_LT(lossy_rmse, 1.5 * sim_rmse) << name << " with 20 % loss: " << lossy_rmse;
  EXPECT_GT(lossy["links"]["dropped_injected"].get<double>(), 0.1 * lossy["links"]["arrived"].get<double>());
  std::printf("[ dds ] %s: final RMSE sim %.5g m, DDS %.5g m (%+.1f %%), DDS with 20 %% loss %.5g m\n",
              name.c_str(), sim_rmse, dds_rmse, 100.0 * (dds_rmse / sim_rmse - 1.0), lossy_rmse);
}

INSTANTIATE_TEST_SUITE_P(Papers002To004, CooperativeOverDds,
                         ::testing::Values(Case{"jacobi", 31, " --set run.rate_hz=20"}, Case{"dgbb", 33, ""},
                                           Case{"multipath_bp", 35, ""}, Case{"dle", 56, kDleFlags},
                                           Case{"dle_tracking", 60, ""}, Case{"joint_field", 66, ""},
                                           Case{"jacobi", 62, kFiveStepsPerWorldStep,
                                                "jacobi_five_steps_per_world_step"}),
                         case_name);

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
    ::testing::Values(Case{"default", 37, " --set run.steps=60 --set network.loss=0.2"},
                      Case{"default", 79,
                           " --set run.steps=60 --set network.loss=0.2 --set algorithm.name=dml", "dml"},
                      Case{"jacobi", 38, " --set run.steps=60 --set network.loss=0.2"},
                      Case{"dgbb", 39, " --set run.steps=150"},
                      Case{"multipath_bp", 40, " --set run.steps=30 --set network.loss=0.2"},
                      Case{"dle_tracking", 58, " --set run.steps=60 --set network.loss=0.2"},
                      Case{"joint_field", 68, " --set run.steps=40 --set network.loss=0.2"},
                      // algorithm.bp_messages=exact (not in 003): each BELIEF lists the messages its sender
                      // summed. Its free run is not in CI (26 s): 2026-12-01, seed 1, DDS 0.36103 m = the
                      // simulator's free run, and 0.36103 m with 20 % loss (cavity messages reach the same
                      // fixed point, later).
                      Case{"multipath_bp", 76,
                           " --set run.steps=30 --set network.loss=0.2 --set algorithm.bp_messages=exact",
                           "multipath_bp_exact"}),
    case_name);

}  // namespace
