// The algorithm keys' parameter blocks (scenario.hpp, algorithms.hpp): a key of a block the chosen
// algorithm does not read is a warning naming its source, and every block is range-checked whatever the
// algorithm (docs/scenario.md, "algorithm").
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/config/scenario.hpp"

namespace swarmloc::config {
namespace {

std::vector<std::string> warnings_of(const std::string& yaml,
                                     const std::vector<std::string>& overrides = {}) {
  std::vector<std::string> warnings;
  (void)parse_scenario(yaml, overrides, "x.yaml", &warnings);
  return warnings;
}

std::vector<std::string> file_warnings(const std::string& file, const std::vector<std::string>& overrides) {
  std::vector<std::string> warnings;
  (void)load_scenario(std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/" + file, overrides, &warnings);
  return warnings;
}

TEST(AlgorithmKeys, AKeyOfABlockTheAlgorithmDoesNotReadIsAWarningWithItsSource) {
  EXPECT_EQ(warnings_of("algorithm:\n  fixed_step: 0.2\n"),
            std::vector<std::string>{"algorithm.fixed_step: a gradient key, not used by ieif (read by dgbb, "
                                     "local_bb, fixed_step, step_length) at x.yaml:2:15"});
  // From --set even at its default: the user asked for it.
  EXPECT_EQ(warnings_of("", {"algorithm.bp_messages=beliefs"}),
            std::vector<std::string>{"algorithm.bp_messages: a multipath key, not used by ieif (read by "
                                     "multipath_bp) (from --set algorithm.bp_messages=beliefs)"});
  const auto warnings =
      warnings_of("algorithm:\n  name: jacobi\n  update_iterations: 3\n  field_warmup_steps: 2\n");
  ASSERT_EQ(warnings.size(), 2U);
  EXPECT_EQ(
      warnings[0].rfind("algorithm.update_iterations: a kalman key, not used by jacobi (read by ieif,", 0),
      0U);
  EXPECT_EQ(
      warnings[1],
      "algorithm.field_warmup_steps: a field key, not used by jacobi (read by joint_field) at x.yaml:4:23");
}

TEST(AlgorithmKeys, NoWarningForABlockTheAlgorithmReadsOrAFileDefault) {
  EXPECT_TRUE(warnings_of("algorithm:\n  name: dgbb\n  fixed_step: 0.2\n  consensus_rounds: 3\n").empty());
  EXPECT_TRUE(warnings_of("algorithm:\n  name: dle\n  initial_information: 1.0e-3\n").empty());
  // A file that lists keys at their defaults is a template (scenarios/default.yaml lists the gradient
  // and kalman keys for dml).
  EXPECT_TRUE(warnings_of("algorithm:\n  consensus_rounds: 20\n  path_variance: range_only\n").empty());
  for (const char* file :
       {"default.yaml", "ieif.yaml", "dgbb.yaml", "dle.yaml", "dle_tracking.yaml", "ea2.yaml", "jacobi.yaml",
        "joint_field.yaml", "multipath_bp.yaml", "default3d.yaml", "drones3d.yaml"}) {
    EXPECT_EQ(file_warnings(file, {}), std::vector<std::string>{}) << file;
  }
  // ieif.yaml's update_iterations: 10 is not a default, and dgbb does not read it.
  const auto warnings = file_warnings("ieif.yaml", {"algorithm.name=dgbb"});
  ASSERT_EQ(warnings.size(), 1U);
  EXPECT_EQ(warnings[0].rfind("algorithm.update_iterations: a kalman key, not used by dgbb (read by ", 0),
            0U);
  EXPECT_NE(warnings[0].find("ieif.yaml:"), std::string::npos);
}

TEST(AlgorithmKeys, EveryBlockIsRangeCheckedWhateverTheAlgorithm) {
  const auto error_of = [](auto change) {
    Scenario s;  // ieif: reads the kalman block only
    change(s);
    try {
      validate(s);
    } catch (const ScenarioError& error) {
      return std::string(error.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(error_of([](Scenario& s) { s.algorithm.gradient.fixed_step = 0.0; }),
            "algorithm.fixed_step: 0 must be > 0");
  EXPECT_EQ(error_of([](Scenario& s) { s.algorithm.gradient.max_move_fraction = 11.0; }),
            "algorithm.max_move_fraction: 11 is outside [0, 10]");
  EXPECT_EQ(error_of([](Scenario& s) { s.algorithm.pose.initial_heading_std_rad = -1.0; }),
            "algorithm.initial_heading_std_rad: -1 must be > 0");
  EXPECT_EQ(error_of([](Scenario& s) { s.algorithm.field.field_warmup_steps = -1; }),
            "algorithm.field_warmup_steps: -1 is outside [0, 1000000]");
  EXPECT_EQ(error_of([](Scenario& s) { s.algorithm.kalman.update_iterations = 0; }),
            "algorithm.update_iterations: 0 is outside [1, 100]");
  EXPECT_EQ(error_of([](Scenario& s) { s.algorithm.multipath.bp_messages = static_cast<BpMessages>(7); }),
            "algorithm.bp_messages: invalid enum value 7");
  EXPECT_EQ(error_of([](Scenario& /*s*/) {}), "accepted");
}

TEST(AlgorithmKeys, TheBlockTableNamesEachBlockOnce) {
  std::vector<std::string> names;
  for (const auto& block : param_blocks()) {
    names.emplace_back(block.name);
    EXPECT_EQ(&param_block_spec(block.block), &block);
  }
  EXPECT_EQ(names, (std::vector<std::string>{"kalman", "pose", "gradient", "field", "multipath"}));
  EXPECT_EQ(algorithms_reading(ParamBlock::kGradient), "dgbb, local_bb, fixed_step, step_length");
  EXPECT_EQ(algorithms_reading(ParamBlock::kPose), "pose_ekf, pose_ieif, team_pose_ekf, dead_reckoning");
  EXPECT_EQ(algorithms_reading(ParamBlock::kField), "joint_field");
}

}  // namespace
}  // namespace swarmloc::config
