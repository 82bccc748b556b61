// MURP trials 13-17 (the validation trials; skipped, with a message, when the dataset is absent) in the
// in-process runner with the built-in calibration fitted on 01-12: issue 40's figures, pooled over every
// ordered pair and window against the window-pose truth (docs/real-data.md, "MURP").
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <utility>

#include "dataset_paths.hpp"
#include "swarmloc/runtime/range_calibration_file.hpp"
#include "swarmloc/sim/murp_team_run.hpp"
#include "swarmloc/world/murp.hpp"

namespace {

using namespace swarmloc;
namespace uwb = estimators::uwb;

world::RelativeErrorStats validation_trials(const uwb::RangeCalibration& calibration, bool cooperate) {
  const auto parsed = swarmloc::testing::murp_parsed(SWARMLOC_SOURCE_DIR);
  world::RelativeErrorStats pooled;
  for (const char* name : {"13", "14", "15", "16", "17"}) {
    const auto trial = world::load_murp_trial(parsed / name);
    sim::MurpTeamOptions options;
    options.cooperate = cooperate;
    for (const auto& pair : trial.pairs) {
      options.models[std::make_pair(pair.base, pair.target)] =
          uwb::range_model(calibration, pair.base, pair.target);
    }
    const auto windows = world::murp_team_windows(trial);
    const auto score = world::score_murp(windows, sim::run_murp_team(windows, options));
    EXPECT_EQ(score.missing_estimates, 0) << name;
    pooled.add(score.pooled);
  }
  return pooled;
}

TEST(SimulatedMurp, ValidationTrialsMeetThePapersPositionErrorAndBeatItsHeadingError) {
  const auto parsed = swarmloc::testing::murp_parsed(SWARMLOC_SOURCE_DIR);
  if (parsed.empty() || !std::filesystem::exists(parsed)) {
    GTEST_SKIP() << "MIT MURP dataset not found (shared/data/mit-murp-uwb/parsed; or SWARMLOC_MURP_DIR)";
  }
  const auto calibration = runtime::builtin_murp_calibration();
  const auto full = validation_trials(calibration, true);
  EXPECT_EQ(full.windows, 6078);
  EXPECT_LE(full.position_mae_m(), 0.24);
  EXPECT_LE(full.heading_mae_deg(), 5.5);
  // Each of the two parts earns its place: without either the error grows.
  EXPECT_GT(validation_trials(uwb::without_bias(calibration), true).position_mae_m(),
            full.position_mae_m() + 0.05);
  EXPECT_GT(validation_trials(calibration, false).position_mae_m(), full.position_mae_m() + 0.02);
}

}  // namespace
