// What identifies a run on the wire (docs/robustness.md, "Run isolation" and "Scenario agreement"):
// dds.run_id's rules, and the two hashes: scenario_hash (the file, without the run id) and results_hash
// (what decides the results, without name and the transport settings).
#include <gtest/gtest.h>

#include "swarmloc/config/scenario.hpp"

namespace swarmloc::config {
namespace {

TEST(RunIdentity, RunIdIsAShortTokenOrEmpty) {
  EXPECT_TRUE(valid_run_id("r0123456789ab"));
  EXPECT_TRUE(valid_run_id("k8s_run-1"));
  EXPECT_FALSE(valid_run_id(""));
  EXPECT_FALSE(valid_run_id(std::string(33, 'a')));
  for (const char* bad : {"a.b", "a*", "a b", "a/b", "a?"}) EXPECT_FALSE(valid_run_id(bad)) << bad;
  EXPECT_NO_THROW(parse_scenario("seed: 1\n", {"dds.run_id=abc"}));
  try {
    parse_scenario("seed: 1\n", {"dds.run_id=a*b"});
    FAIL() << "a wildcard in dds.run_id must be refused";
  } catch (const ScenarioError& error) {
    EXPECT_NE(std::string(error.what()).find("dds.run_id"), std::string::npos) << error.what();
  }
}

TEST(RunIdentity, TheRunIdTravelsInTheYamlButNotInTheScenarioHash) {
  Scenario a;
  Scenario b;
  b.dds.run_id = "r1";
  EXPECT_EQ(scenario_hash(a), scenario_hash(b));
  EXPECT_EQ(parse_scenario(to_yaml(b)).dds.run_id, "r1");
}

TEST(RunIdentity, ResultsHashIgnoresNameAndTransportButNothingElse) {
  const Scenario base;
  Scenario transport = base;
  transport.name = "other";
  transport.dds.domain_id = 7;
  transport.dds.interface = "eth0";
  transport.dds.peer_address = "10.0.0.2";
  transport.dds.run_id = "x";
  EXPECT_EQ(results_hash(base), results_hash(transport));
  Scenario seed = base;
  seed.seed = base.seed + 1;
  EXPECT_NE(results_hash(base), results_hash(seed));
  Scenario loss = base;
  loss.network.loss = 0.25;
  EXPECT_NE(results_hash(base), results_hash(loss));
  Scenario steps = base;
  steps.run.steps = base.run.steps + 1;
  EXPECT_NE(results_hash(base), results_hash(steps));
}

}  // namespace
}  // namespace swarmloc::config
