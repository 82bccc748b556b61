// `name` names the run directory (runs/<name>-<stamp>-seed<seed>): validate() keeps it one path component
// of a sane length (docs/robustness.md, "Outputs are complete or the run fails").
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "swarmloc/config/scenario.hpp"

namespace swarmloc::config {
namespace {

/// The ScenarioError message for `name` (set in the struct, as --set would after YAML folding), or "".
std::string name_error(const std::string& name) {
  Scenario scenario;
  scenario.name = name;
  try {
    validate(scenario);
  } catch (const ScenarioError& error) {
    return error.what();
  }
  return {};
}

TEST(NameValidation, RefusesNamesThatLeaveOneDirectoryOrAreNotFileNames) {
  const std::vector<std::string> refused{"",
                                         "a/b",
                                         "../escape",
                                         "..",
                                         "x..y",
                                         ".hidden",
                                         std::string("tab\there"),
                                         std::string("nl\nx"),
                                         std::string("del\x7f"),
                                         std::string(101, 'n')};
  for (const auto& name : refused) {
    const auto message = name_error(name);
    EXPECT_EQ(message.rfind("name: ", 0), 0u) << "name '" << name << "' gave: '" << message << "'";
  }
  // From the command line too, before anything runs.
  EXPECT_THROW(parse_scenario("", {"name=../up"}), ScenarioError);
}

TEST(NameValidation, AcceptsOrdinaryNamesUpToOneHundredBytes) {
  const std::vector<std::string> accepted{"default", "loss sweep 0.2", "x';touch INJECTED;'", "a.b-c_d",
                                          std::string(100, 'n')};
  for (const auto& name : accepted) {
    EXPECT_EQ(name_error(name), "") << name;
  }
}

}  // namespace
}  // namespace swarmloc::config
