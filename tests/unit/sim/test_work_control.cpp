// Progress and cancellation of long computations (world.hpp WorkControl): a set flag stops world
// building and Monte Carlo with world::Cancelled, and a simulation with the steps done marked interrupted —
// the same steps, bit for bit, as an uninterrupted run. A prebuilt world runs like a built one.
#include <gtest/gtest.h>

#include <atomic>
#include <bit>

#include "swarmloc/sim/simulator.hpp"

namespace swarmloc::sim {
namespace {

config::Scenario scenario() {
  config::Scenario s;
  s.seed = 5;
  s.world.agents = 40;
  s.world.anchors = 8;
  s.run.steps = 30;
  s.world.motion = config::Motion::kRandomWalk;
  s.world.motion_std_m = 0.05;
  return s;
}

std::uint64_t bit_pattern(double v) { return std::bit_cast<std::uint64_t>(v); }

TEST(WorkControl, ASetFlagStopsWorldBuildingAndMonteCarlo) {
  std::atomic<bool> cancel{true};
  world::WorkControl control;
  control.cancel = &cancel;
  EXPECT_THROW((void)world::build_world(scenario(), 0, -1, control), world::Cancelled);
  EXPECT_THROW((void)run_monte_carlo(scenario(), 4, 2, {}, {}, &cancel), world::Cancelled);
  cancel = false;
  const world::World built = world::build_world(scenario(), 0, -1, control);
  EXPECT_EQ(built.neighbours, world::build_world(scenario()).neighbours);
}

TEST(WorkControl, AnInterruptedSimulationKeepsTheStepsDoneBitForBit) {
  const auto s = scenario();
  for (int threads : {1, 2}) {
    SimOptions plain;
    plain.round_threads = threads;
    const auto full = run_simulation(s, plain);
    ASSERT_FALSE(full.interrupted);

    std::atomic<bool> cancel{false};
    SimOptions options;
    options.round_threads = threads;
    options.control.cancel = &cancel;
    options.on_step = [&](std::int64_t step, const world::ErrorStats&) {
      if (step == 11) cancel = true;  // as Ctrl-C would, between two steps
    };
    const auto cut = run_simulation(s, world::build_world(s), options);
    EXPECT_TRUE(cut.interrupted);
    ASSERT_EQ(cut.metrics.size(), 12u) << threads << " threads";
    for (std::size_t k = 0; k < cut.metrics.size(); ++k) {
      EXPECT_EQ(bit_pattern(cut.metrics[k].errors.rmse_m), bit_pattern(full.metrics[k].errors.rmse_m))
          << "step " << k;
      EXPECT_EQ(bit_pattern(cut.metrics[k].errors.nees), bit_pattern(full.metrics[k].errors.nees))
          << "step " << k;
    }
    EXPECT_EQ(cut.agent_summaries.size(), 40u);
    EXPECT_FALSE(cut.links.empty());
  }
}

TEST(WorkControl, APrebuiltWorldRunsLikeABuiltOne) {
  const auto s = scenario();
  const auto built = run_simulation(s);
  const auto given = run_simulation(s, world::build_world(s), {});
  ASSERT_EQ(built.metrics.size(), given.metrics.size());
  for (std::size_t k = 0; k < built.metrics.size(); ++k)
    EXPECT_EQ(bit_pattern(built.metrics[k].errors.rmse_m), bit_pattern(given.metrics[k].errors.rmse_m));
  EXPECT_EQ(built.links.size(), given.links.size());
}

}  // namespace
}  // namespace swarmloc::sim
