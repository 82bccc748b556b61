// Small seeded versions of the paper reproductions that live in `swarmloc reproduce` (the full runs
// and their results are in docs/reproduction.md).
#include <gtest/gtest.h>

#include "reproduce.hpp"

namespace swarmloc::orchestrator {
namespace {

// 001 Table I, noise std 0.2 m column, 8 trials: the paper's mean error is 4.38 cm (IEIF) and
// 2.30 cm (IEKF); ours must be no worse than 1.5x and must converge in every trial.
TEST(KalmanTables, Table1MeanErrorsAtTwentyCentimetreNoiseAreNoWorseThanThePaper) {
  const auto ieif = run_kalman_table_column("ieif", 90, 30, 0.2, 8, 0, 1);
  const auto iekf = run_kalman_table_column("iekf", 90, 30, 0.2, 8, 0, 1);
  EXPECT_LE(ieif.mean_error_cm, 1.5 * 4.38);
  EXPECT_LE(iekf.mean_error_cm, 1.5 * 2.30);
  EXPECT_GT(ieif.mean_error_cm, 0.1) << "an error below 1 mm at 0.2 m noise would mean scoring is broken";
  EXPECT_EQ(ieif.failure_percent, 0.0);
  EXPECT_EQ(iekf.failure_percent, 0.0);
  EXPECT_LE(ieif.max_error_cm, 1.5 * 11.64);
}

}  // namespace
}  // namespace swarmloc::orchestrator
