// A simulated run's recording and its replay in the simulator (docs/record-replay.md): every step's metrics
// and estimates bit for bit for both schedules, the fusion centre and the cooperative families; another
// algorithm on the recorded input; a version 3 recording. The recording format itself:
// tests/unit/rundir/test_recording.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "process_helpers.hpp"
#include "recording_bytes.hpp"
#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/rundir/recording.hpp"
#include "swarmloc/rundir/run_record.hpp"
#include "swarmloc/sim/simulator.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::sim {
namespace {

config::Scenario replay_scenario() {
  config::Scenario s;
  s.seed = 11;
  s.world.agents = 30;
  s.world.anchors = 8;
  s.run.steps = 40;
  return s;
}

void expect_same_metrics(const rundir::RunRecord& a, const rundir::RunRecord& b) {
  ASSERT_EQ(a.metrics.size(), b.metrics.size());
  for (std::size_t k = 0; k < a.metrics.size(); ++k) {
    // Bit for bit (NEES is NaN where no agent has a covariance, e.g. dgbb).
    EXPECT_BITS(a.metrics[k].errors.rmse_m, b.metrics[k].errors.rmse_m) << "step " << k;
    EXPECT_BITS(a.metrics[k].errors.max_error_m, b.metrics[k].errors.max_error_m) << "step " << k;
    EXPECT_BITS(a.metrics[k].errors.nees, b.metrics[k].errors.nees) << "step " << k;
    EXPECT_BITS(a.metrics[k].crlb_rmse_m, b.metrics[k].crlb_rmse_m) << "step " << k;
    // The optimum of the run's data (docs/algorithms.md §1.3.2): a replay holds the same data.
    EXPECT_BITS(a.metrics[k].optimum_rmse_m, b.metrics[k].optimum_rmse_m) << "step " << k;
  }
  ASSERT_EQ(a.estimates.size(), b.estimates.size());
  for (std::size_t k = 0; k < a.estimates.size(); ++k) {
    EXPECT_EQ(a.estimates[k].estimate.mean_m, b.estimates[k].estimate.mean_m);
    EXPECT_EQ(a.estimates[k].truth, b.estimates[k].truth);
  }
  EXPECT_EQ(rundir::link_totals(a).delivered, rundir::link_totals(b).delivered);
}

/// Runs `s` in the simulator, recording its measurements into `dir`.
rundir::RunRecord record_run(const config::Scenario& s, const std::filesystem::path& dir) {
  rundir::DirectoryRecorder recorder(dir);
  SimOptions options;
  options.recorder = &recorder;
  auto run = run_simulation(s, options);
  recorder.close();
  return run;
}

struct ReplayCase {
  const char* name;
  void (*configure)(config::Scenario&);
};

class SimulatorReplay : public ::testing::TestWithParam<ReplayCase> {};

TEST_P(SimulatorReplay, ReplayOfARecordedRunGivesTheSameMetricsEveryStep) {
  auto s = replay_scenario();
  GetParam().configure(s);
  const auto dir = testing::fresh_directory(std::string("replay-") + GetParam().name);
  rundir::DirectoryRecorder recorder(dir);
  SimOptions record_options;
  record_options.recorder = &recorder;
  const auto recorded_run = run_simulation(s, record_options);
  recorder.close();
  EXPECT_EQ(recorder.steps(), s.run.steps);

  const auto recording = rundir::load_recording(dir / rundir::kRecordingFile);
  ASSERT_EQ(recording->steps(), s.run.steps);
  EXPECT_EQ(recording->world().difference(world::build_world(s)), "");
  SimOptions replay_options;
  replay_options.recorded = recording;
  const auto replayed = run_simulation(s, replay_options);
  expect_same_metrics(recorded_run, replayed);
  std::printf("  %s: recorded final RMSE %.12f m, replayed %.12f m\n", GetParam().name,
              recorded_run.final_metrics()->errors.rmse_m, replayed.final_metrics()->errors.rmse_m);

  // The sample log: every sample reached a neighbour of its sender.
  const auto log = rundir::load_sample_log(dir / rundir::kSampleLogDirectory / rundir::kSimSampleLogFile);
  EXPECT_EQ(log.samples.size(), recorder.samples());
  if (config::runs_in_fusion_centre(s.algorithm.name)) {
    EXPECT_TRUE(log.samples.empty());  // sensors only: nothing between agents
    return;
  }
  ASSERT_FALSE(log.samples.empty());
  const auto world = world::build_world(s);
  for (const auto& sample : log.samples) {
    const auto& neighbours = world.neighbours[static_cast<std::size_t>(sample.receiver)];
    ASSERT_TRUE(std::binary_search(neighbours.begin(), neighbours.end(), sample.header.agent_id));
    ASSERT_LE(sample.source_timestamp_ns, sample.take_ns);
  }
}

INSTANTIATE_TEST_SUITE_P(
    Runtimes, SimulatorReplay,
    ::testing::Values(ReplayCase{"ieif_random_walk_loss",
                                 [](config::Scenario& s) {
                                   s.world.motion = config::Motion::kRandomWalk;
                                   s.world.motion_std_m = 0.05;
                                   s.network.loss = 0.2;
                                 }},
                      ReplayCase{"iekf_agent_clocks",
                                 [](config::Scenario& s) {
                                   s.algorithm.name = "iekf";
                                   s.run.sim_clock = config::SimClock::kAgents;
                                   s.network.delay_ms = 3.0;
                                   s.network.jitter_ms = 20.0;
                                   s.clock.drift_ppm = 500.0;
                                 }},
                      ReplayCase{"ekf_fusion_centre", [](config::Scenario& s) { s.algorithm.name = "ekf"; }},
                      ReplayCase{"dgbb", [](config::Scenario& s) { s.algorithm.name = "dgbb"; }},
                      ReplayCase{"jacobi", [](config::Scenario& s) { s.algorithm.name = "jacobi"; }}),
    [](const ::testing::TestParamInfo<ReplayCase>& param) { return std::string(param.param.name); });

TEST(SimulatorReplay, AnotherAlgorithmOnTheRecordedInputMatchesItsOwnRunAndDiffers) {
  // ieif and iekf consume the same measurement kinds, so iekf replayed on ieif's recording sees
  // exactly what an iekf run of the same seed generates — and ends somewhere else than ieif.
  auto s = replay_scenario();
  s.world.motion = config::Motion::kRandomWalk;
  s.world.motion_std_m = 0.05;
  const auto dir = testing::fresh_directory("other-algorithm");
  const auto ieif = record_run(s, dir);

  auto other = s;
  other.algorithm.name = "iekf";
  SimOptions replay_options;
  replay_options.recorded = rundir::load_recording(dir / rundir::kRecordingFile);
  const auto replayed = run_simulation(other, replay_options);
  const auto direct = run_simulation(other);
  expect_same_metrics(direct, replayed);
  EXPECT_NE(replayed.final_metrics()->errors.rmse_m, ieif.final_metrics()->errors.rmse_m);
  EXPECT_TRUE(std::isfinite(replayed.final_metrics()->errors.rmse_m));

  // The measurements really come from the file: with another noise level the generator would draw
  // other ranges, the replay feeds the recorded ones (ieif takes each range's std from its batch).
  auto noisier = s;
  noisier.noise.range_std_m = 1.0;
  EXPECT_EQ(run_simulation(noisier, replay_options).final_metrics()->errors.rmse_m,
            ieif.final_metrics()->errors.rmse_m);
  EXPECT_NE(run_simulation(noisier).final_metrics()->errors.rmse_m, ieif.final_metrics()->errors.rmse_m);

  // A shorter replay is a prefix.
  auto shorter = s;
  shorter.run.steps = 10;
  const auto prefix = run_simulation(shorter, replay_options);
  ASSERT_EQ(prefix.metrics.size(), 10u);
  EXPECT_EQ(prefix.metrics.back().errors.rmse_m, ieif.metrics[9].errors.rmse_m);
}

TEST(Recording, AVersionThreeRecordingReplaysLikeItsVersionFourOriginal) {
  const auto s = replay_scenario();
  const auto dir = testing::fresh_directory("replay-v3");
  const auto recorded_run = record_run(s, dir);
  const auto v3 = testing::without_checksums(testing::read_bytes(dir / rundir::kRecordingFile), 3);
  SimOptions replay_options;
  replay_options.recorded = rundir::parse_recording(v3, "v3.slrec");
  expect_same_metrics(recorded_run, run_simulation(s, replay_options));
}

}  // namespace
}  // namespace swarmloc::sim
