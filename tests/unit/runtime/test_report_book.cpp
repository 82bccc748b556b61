// The orchestrator's newest report per agent across a scheduled kill and restart.
#include <gtest/gtest.h>

#include "swarmloc/runtime/report_book.hpp"

namespace swarmloc::runtime {
namespace {

EstimateReport report_of(AgentId agent, std::uint32_t steps_run) {
  EstimateReport report;
  report.header.agent_id = agent;
  report.steps_run = steps_run;
  report.estimate.mean_m = Vec2(static_cast<double>(steps_run), 0.0);
  return report;
}

TEST(ReportBook, KeepsTheNewestReportAndDropsOlderOnesAndUnknownAgents) {
  ReportBook book(2);
  EXPECT_TRUE(book.take(report_of(1, 5)));
  EXPECT_FALSE(book.take(report_of(1, 4)));  // overtaken by a newer one
  EXPECT_TRUE(book.take(report_of(1, 5)));   // the same step again (a hello, a settle report)
  EXPECT_FALSE(book.take(report_of(2, 1)));
  EXPECT_FALSE(book.take(report_of(-1, 1)));
  ASSERT_TRUE(book[1].has_value());
  EXPECT_EQ(book[1]->steps_run, 5U);
  EXPECT_FALSE(book[0].has_value());
}

TEST(ReportBook, ARestartedAgentIsHeardThoughTheDeadProcessReportedAfterItsKill) {
  // CI saw it over DDS (FaultsOverDds.Killed…, 2026-12-02): agent 1's last report of step 61 was taken
  // after the kill had emptied its slot, and its restart's reports (steps 1-49) were all "older".
  ReportBook book(3);
  ASSERT_TRUE(book.take(report_of(1, 60)));
  book.killed(1);
  EXPECT_FALSE(book[1].has_value());
  EXPECT_FALSE(book.take(report_of(1, 61)));  // still in the reader when the process died
  EXPECT_FALSE(book[1].has_value());
  book.restarted(1);
  EXPECT_TRUE(book.take(report_of(1, 1)));
  ASSERT_TRUE(book[1].has_value());
  EXPECT_EQ(book[1]->steps_run, 1U);
  EXPECT_TRUE(book.take(report_of(1, 2)));
  EXPECT_EQ(book[1]->estimate.mean_m.x(), 2.0);
  // The other agents are untouched.
  EXPECT_TRUE(book.take(report_of(2, 70)));
  int held = 0;
  for (const auto& slot : book) held += slot ? 1 : 0;
  EXPECT_EQ(held, 2);
}

}  // namespace
}  // namespace swarmloc::runtime
