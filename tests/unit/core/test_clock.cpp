#include <gtest/gtest.h>

#include <cmath>

#include "swarmloc/core/clock.hpp"

namespace swarmloc::core {
namespace {

TEST(ClockModel, MonoDurationInvertsTheLocalRate) {
  const ClockModel clock{2.5, 150.0};
  for (const double mono : {0.0, 1.0, 1234.5}) {
    for (const double local_dt : {1e-3, 0.1, 10.0}) {
      const double later = clock.local_time(mono + clock.mono_duration(local_dt));
      EXPECT_NEAR(later - clock.local_time(mono), local_dt, 1e-9);
    }
  }
  EXPECT_DOUBLE_EQ(clock.local_time(0.0), 2.5);
  EXPECT_NEAR(clock.local_time(1.0) - clock.local_time(0.0), 1.0 + 150e-6, 1e-15);
}

TEST(ClockModel, IdealClockIsTheIdentity) {
  const ClockModel ideal;
  EXPECT_DOUBLE_EQ(ideal.local_time(3.25), 3.25);
  EXPECT_DOUBLE_EQ(ideal.mono_duration(0.5), 0.5);
}

TEST(DrawClock, StaysWithinBoundsAndIsDeterministic) {
  double min_offset = 1.0;
  double max_offset = -1.0;
  for (std::int32_t id = 0; id < 2000; ++id) {
    const ClockModel c = draw_clock(42, id, 0.5, 100.0);
    EXPECT_LE(std::abs(c.offset_s), 0.5);
    EXPECT_LE(std::abs(c.drift_ppm), 100.0);
    const ClockModel again = draw_clock(42, id, 0.5, 100.0);
    EXPECT_EQ(c.offset_s, again.offset_s);
    EXPECT_EQ(c.drift_ppm, again.drift_ppm);
    min_offset = std::min(min_offset, c.offset_s);
    max_offset = std::max(max_offset, c.offset_s);
  }
  EXPECT_LT(min_offset, -0.45);  // the whole range is used
  EXPECT_GT(max_offset, 0.45);
}

TEST(DrawClock, DiffersAcrossAgentsAndSeeds) {
  EXPECT_NE(draw_clock(1, 0, 1.0, 50.0).offset_s, draw_clock(1, 1, 1.0, 50.0).offset_s);
  EXPECT_NE(draw_clock(1, 0, 1.0, 50.0).offset_s, draw_clock(2, 0, 1.0, 50.0).offset_s);
  const ClockModel zero = draw_clock(1, 0, 0.0, 0.0);
  EXPECT_EQ(zero.offset_s, 0.0);
  EXPECT_EQ(zero.drift_ppm, 0.0);
}

}  // namespace
}  // namespace swarmloc::core
