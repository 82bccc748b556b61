// Live deployment files (config/deployment.hpp, docs/live.md).
#include <gtest/gtest.h>

#include "swarmloc/config/deployment.hpp"

namespace {

using swarmloc::config::DeploymentError;
using swarmloc::config::parse_deployment;

const char* const kDeploymentLab = R"(
name: lab
domain_id: 7
rate_hz: 5
algorithm: dml
set: [noise.range_std_m=0.2]
frames: {map: world, base: base_footprint}
topics: {truth: mocap}
team:
  - {name: bot_b, id: 1, start: [2, 3]}
  - {name: bot_a, id: 0}
  - {name: uwb0, id: 2, anchor: [0, 0]}
  - {name: uwb1, id: 3, anchor: [10, 0]}
)";

TEST(Deployment, ParsesTheTeamInIdOrderAndTheNames) {
  const auto d = parse_deployment(kDeploymentLab);
  ASSERT_EQ(d.team.size(), 4U);
  EXPECT_EQ(d.team[0].name, "bot_a");
  EXPECT_EQ(d.team[1].start, swarmloc::Vec2(2, 3));
  EXPECT_TRUE(d.team[3].anchor.has_value());
  EXPECT_EQ(d.map_frame, "world");
  EXPECT_EQ(d.base_frame, "base_footprint");
  EXPECT_EQ(d.truth_topic, "mocap");
  EXPECT_EQ(d.find("uwb1")->id, 3);
  EXPECT_EQ(d.find("nobody"), nullptr);
  EXPECT_EQ(swarmloc::config::Deployment::dds_topic("bot_a", "ranges"), "rt/bot_a/ranges");
}

TEST(Deployment, BecomesTheAgentsScenario) {
  const auto s = swarmloc::config::deployment_scenario(parse_deployment(kDeploymentLab));
  EXPECT_EQ(s.algorithm.name, "dml");
  EXPECT_EQ(s.world.agents, 4);
  EXPECT_EQ(s.world.anchors, 2);
  EXPECT_DOUBLE_EQ(s.run.rate_hz, 5.0);
  EXPECT_EQ(s.dds.domain_id, 7);
  EXPECT_EQ(s.dds.run_id, "lab");
  EXPECT_DOUBLE_EQ(s.noise.range_std_m, 0.2);
}

void expect_deployment_error(const std::string& text, const std::string& needle) {
  try {
    parse_deployment(text, "lab.yaml");
    ADD_FAILURE() << "accepted: " << text;
  } catch (const DeploymentError& error) {
    EXPECT_NE(std::string(error.what()).find(needle), std::string::npos) << error.what();
  }
}

TEST(Deployment, RefusesBadFilesNamingTheKey) {
  expect_deployment_error("team: [{name: a, id: 1}]", "ids must be 0");
  expect_deployment_error("team: [{name: a, id: 0}, {name: a, id: 1}]", "repeats");
  expect_deployment_error("team: [{name: 3a, id: 0}]", "not a ROS name");
  expect_deployment_error("team: [{name: a, id: 0, anchor: [1, 2]}]", "only anchors");
  expect_deployment_error("team: [{name: a, id: 0, anchor: [1]}, {name: b, id: 1}]", "team[0].anchor");
  expect_deployment_error("team: [{name: a, id: 0}]\nrate: 3", "rate: unknown key");
  expect_deployment_error("team: [{name: a, id: 0}]\nalgorithm: nonsense", "algorithm");
  expect_deployment_error("team: [{name: a, id: 0}]\nlimits: {silence_s: 0}", "limits.silence_s");
  expect_deployment_error("[1, 2]", "a YAML map");
}

}  // namespace
