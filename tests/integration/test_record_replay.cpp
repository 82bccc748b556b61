// `--record` and `swarmloc replay` end to end with the real binary: a simulator recording replayed
// gives the same final error; a short lockstep DDS run leaves a recording and per-agent sample logs,
// and its recording replays in the simulator and over DDS. Domain 230 (the highest valid id; the runs are
// sequential).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "process_helpers.hpp"
#include "swarmloc/rundir/recording.hpp"

namespace record_replay_test {
namespace {

using swarmloc::testing::count_processes_matching;
using swarmloc::testing::fresh_directory;
using swarmloc::testing::read_json;
using swarmloc::testing::run_command;

const std::string kBinary = SWARMLOC_BINARY;
const std::string kScenario = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/ieif.yaml";

double final_rmse(const std::filesystem::path& run_dir) {
  return read_json(run_dir / "summary.json")["final"]["rmse_m"].get<double>();
}

TEST(RecordReplay, SimulatorRecordingReplaysToTheSameFinalErrorAndOtherAlgorithmsRunOnIt) {
  const auto root = fresh_directory("record-replay-sim");
  const auto recorded = root / "recorded";
  const auto run =
      run_command(kBinary + " sim " + kScenario + " -q --record --out " + recorded.string() +
                  " --set run.steps=60 --set world.motion=random_walk --set world.motion_std_m=0.05 "
                  "--set network.loss=0.2");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const auto file = recorded / swarmloc::rundir::kRecordingFile;
  const auto summary = read_json(recorded / "summary.json");
  EXPECT_EQ(summary["recording"]["steps"], 60);
  EXPECT_GT(summary["recording"]["samples"].get<double>(), 0.0);

  const auto replayed = root / "replayed";
  const auto replay = run_command(kBinary + " replay " + file.string() + " -q --out " + replayed.string());
  ASSERT_EQ(replay.exit_code, 0) << replay.output;
  const double a = final_rmse(recorded);
  const double b = final_rmse(replayed);
  std::printf("  sim --record final RMSE %.12f m, replay %.12f m\n", a, b);
  EXPECT_NEAR(a, b, 1e-9);
  const auto provenance = read_json(replayed / "summary.json")["replay"];
  EXPECT_EQ(provenance["recorded_steps"], 60);
  EXPECT_EQ(provenance["recorded_algorithm"], "ieif");

  const auto other = root / "iekf";
  const auto iekf = run_command(kBinary + " replay " + file.string() +
                                " -q --set algorithm.name=iekf --out " + other.string());
  ASSERT_EQ(iekf.exit_code, 0) << iekf.output;
  EXPECT_EQ(read_json(other / "summary.json")["algorithm"], "iekf");
  EXPECT_NE(final_rmse(other), a);

  // Bad input is exit 2 with a clear message.
  auto expect_rejected = [&](const std::string& args, const std::string& message) {
    const auto result =
        run_command(kBinary + " replay " + args + " -q --out " + (root / "rejected").string());
    EXPECT_EQ(result.exit_code, 2) << result.output;
    EXPECT_NE(result.output.find(message), std::string::npos) << result.output;
  };
  expect_rejected(file.string() + " --set world.agents=10",
                  "--set world.agents would change the recorded world");
  expect_rejected(file.string() + " --set seed=2", "--set seed would change the recorded world");
  expect_rejected(file.string() + " --set run.steps=61", "run.steps: 61 steps asked but");
  expect_rejected(file.string() + " --set algorithm.name=jacobi",
                  "algorithm.name: jacobi consumes relative positions");
  expect_rejected((root / "missing.slrec").string(), "cannot be read");
  const auto sample_log =
      recorded / swarmloc::rundir::kSampleLogDirectory / swarmloc::rundir::kSimSampleLogFile;
  expect_rejected(sample_log.string(), "is a sample log");
  {
    std::filesystem::copy_file(file, root / "cut.slrec");
    std::filesystem::resize_file(root / "cut.slrec", std::filesystem::file_size(file) / 2);
  }
  // Where the cut lands decides the wording ("truncated", "count N exceeds the bytes left"); every
  // message names the file and the byte offset.
  expect_rejected((root / "cut.slrec").string(), "cut.slrec: byte ");
  EXPECT_EQ(
      run_command(kBinary + " sim " + kScenario + " -q --record --trials 2 --out " + (root / "mc").string())
          .exit_code,
      2);
}

TEST(RecordReplay, LockstepDdsRunRecordsBatchesAndSamplesAndReplaysInBothRuntimes) {
  const auto root = fresh_directory("record-replay-dds");
  const std::string small =
      " -q --set world.agents=8 --set world.anchors=3 --set world.area_m=20 "
      "--set run.steps=30 --set run.rate_hz=20 --set run.mode=lockstep";
  const auto recorded = root / "dds";
  const auto run = run_command(kBinary + " run " + kScenario + small +
                               " --set dds.domain_id=230 --record --out " + recorded.string());
  ASSERT_TRUE(swarmloc::testing::completed_run(run.exit_code)) << run.output;
  EXPECT_EQ(count_processes_matching(recorded.string()), 0) << "agent processes outlived the run";

  const auto recording = swarmloc::rundir::load_recording(recorded / swarmloc::rundir::kRecordingFile);
  EXPECT_EQ(recording->agents(), 8);
  EXPECT_EQ(recording->steps(), 30);
  std::size_t ranges = 0;
  for (std::int64_t step = 0; step < recording->steps(); ++step) {
    for (int i = 0; i < 8; ++i) ranges += recording->batch(i, step).ranges.size();
  }
  EXPECT_GT(ranges, 0u);
  for (int i = 0; i < 8; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "agent_%03d.slrec", i);
    const auto log =
        swarmloc::rundir::load_sample_log(recorded / swarmloc::rundir::kSampleLogDirectory / name);
    EXPECT_TRUE(log.complete) << name;
    EXPECT_GT(log.samples.size(), 30u) << name;  // at least one state per step from some neighbour
    for (const auto& sample : log.samples) {
      EXPECT_EQ(sample.receiver, i);
      EXPECT_GT(sample.source_timestamp_ns, 0);
      EXPECT_GE(sample.take_ns, sample.source_timestamp_ns - 1'000'000);  // one host, one clock
    }
  }

  // Lockstep DDS runs equal the simulator (LockstepOverDds), so the replays equal the recorded run.
  const auto in_sim = root / "replay-sim";
  const auto sim = run_command(kBinary + " replay " + (recorded / swarmloc::rundir::kRecordingFile).string() +
                               " -q --out " + in_sim.string());
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  const auto over_dds = root / "replay-dds";
  const auto dds = run_command(kBinary + " replay " + (recorded / swarmloc::rundir::kRecordingFile).string() +
                               " --dds -q --set dds.domain_id=230 --out " + over_dds.string());
  ASSERT_TRUE(swarmloc::testing::completed_run(dds.exit_code)) << dds.output;
  EXPECT_EQ(count_processes_matching(over_dds.string()), 0) << "agent processes outlived the replay";
  const double a = final_rmse(recorded), b = final_rmse(in_sim), c = final_rmse(over_dds);
  std::printf("  dds --record final RMSE %.12f m, replay in sim %.12f m, replay over DDS %.12f m\n", a, b, c);
  EXPECT_NEAR(a, b, 1e-9);
  EXPECT_NEAR(a, c, 1e-9);
  EXPECT_EQ(read_json(over_dds / "summary.json")["mode"], "dds-lockstep");
}

}  // namespace
}  // namespace record_replay_test
