// The algorithm registry (config/algorithms.hpp) and its builders (estimators/registry.hpp) describe the
// same algorithms, entry for entry; every entry is accepted by config, builds, and runs in the runner its
// placement names. The consistency rules are one function so that mutated copies of the tables (an entry
// removed, a placement flipped) can be shown to fail them.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/estimators/registry.hpp"
#include "swarmloc/sim/centralized_runner.hpp"
#include "swarmloc/sim/simulator.hpp"
#include "swarmloc/world/bound.hpp"

namespace swarmloc::sim {
namespace {

using config::AlgorithmFamily;
using config::AlgorithmPlacement;
using config::AlgorithmSpec;
using estimators::EstimatorBuilder;
using estimators::ParamBlock;

/// Every way the two tables can disagree, one line each (empty: consistent).
std::vector<std::string> registry_problems(const std::vector<AlgorithmSpec>& specs,
                                           const std::vector<EstimatorBuilder>& builders) {
  std::vector<std::string> problems;
  std::set<std::string_view> names;
  for (const auto& spec : specs) {
    const std::string name(spec.name);
    if (!names.insert(spec.name).second) problems.push_back(name + ": two entries");
    const auto builder = std::find_if(builders.begin(), builders.end(),
                                      [&](const EstimatorBuilder& b) { return b.name == spec.name; });
    if (builder == builders.end()) {
      problems.push_back(name + ": no builder");
      continue;
    }
    const bool centre = spec.placement == AlgorithmPlacement::kFusionCentre;
    if (centre != (builder->params == ParamBlock::kFusion) || centre != builder->fusion.has_value() ||
        centre == (builder->agent != nullptr)) {
      problems.push_back(name + ": placement disagrees with its builder");
    }
    if (centre != (spec.family == AlgorithmFamily::kCentralized))
      problems.push_back(name + ": placement disagrees with its family");
    // The fusion centre takes one range per edge and every anchor's fix (centralized_measurements).
    if (centre && (spec.bound.draws != config::RangeDraws::kOnePerEdge || !spec.kinds.anchor_fixes))
      problems.push_back(name + ": fusion-centre bound data is not one range per edge with fixes");
    if (spec.exchange_only != (builder->params == ParamBlock::kCooperative))
      problems.push_back(name + ": exchange_only disagrees with its parameter block");
    if (spec.bound.model == config::BoundModel::kRanges && !spec.kinds.ranges)
      problems.push_back(name + ": range bound without ranges");
    if (spec.bound.model == config::BoundModel::kNone && spec.bound.none_reason.empty())
      problems.push_back(name + ": no bound and no reason");
  }
  for (const auto& builder : builders) {
    if (!names.contains(builder.name))
      problems.push_back(std::string(builder.name) + ": builder without entry");
  }
  return problems;
}

std::string joined(const std::vector<std::string>& lines) {
  std::string out;
  for (const auto& line : lines) out += line + "\n";
  return out;
}

TEST(AlgorithmRegistry, EntriesAndBuildersAreConsistent) {
  EXPECT_EQ(joined(registry_problems(config::algorithm_registry(), estimators::estimator_builders())), "");
}

TEST(AlgorithmRegistry, MutantsFailTheConsistencyCheck) {
  const auto& specs = config::algorithm_registry();
  const auto& builders = estimators::estimator_builders();
  auto removed = specs;
  removed.erase(
      std::find_if(removed.begin(), removed.end(), [](const auto& s) { return s.name == "lbekf_i"; }));
  EXPECT_NE(joined(registry_problems(removed, builders)).find("lbekf_i: builder without entry"),
            std::string::npos);
  auto no_builder = builders;
  no_builder.erase(no_builder.begin());
  EXPECT_FALSE(registry_problems(specs, no_builder).empty());
  auto misplaced = specs;
  std::find_if(misplaced.begin(), misplaced.end(), [](const auto& s) { return s.name == "ekf"; })->placement =
      AlgorithmPlacement::kAgent;
  EXPECT_NE(joined(registry_problems(misplaced, builders)).find("ekf: placement disagrees"),
            std::string::npos);
}

TEST(AlgorithmRegistry, ConfigAcceptsExactlyTheEntries) {
  std::vector<std::string> names;
  for (const auto& spec : config::algorithm_registry()) {
    names.emplace_back(spec.name);
    EXPECT_EQ(&config::algorithm_spec(spec.name), &spec);
    EXPECT_EQ(bound_data(std::string(spec.name)).algorithm, spec.name);
    EXPECT_EQ(config::runs_in_fusion_centre(spec.name), spec.placement == AlgorithmPlacement::kFusionCentre)
        << spec.name;
  }
  EXPECT_EQ(bound_data_table().size(), names.size());
  EXPECT_EQ(config::known_algorithm_list().find("no_such"), std::string::npos);
  EXPECT_THROW((void)config::algorithm_spec("no_such"), config::ScenarioError);
  EXPECT_FALSE(config::runs_in_fusion_centre("no_such"));
  std::vector<std::string> exchange_only;
  for (const auto& spec : config::algorithm_registry())
    if (spec.exchange_only) exchange_only.emplace_back(spec.name);
  EXPECT_EQ(config::exchange_only_algorithms(), exchange_only);
  EXPECT_EQ(estimators::cooperative_algorithms(), exchange_only);
}

/// A small valid scenario for `spec`: scenarios/<name>.yaml if there is one, else its family's.
config::Scenario small_scenario(const AlgorithmSpec& spec) {
  const std::string dir = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/";
  std::string path = dir + std::string(spec.name) + ".yaml";
  if (!std::filesystem::exists(path)) {
    path = spec.family == AlgorithmFamily::kCentralized ? dir + "ea2.yaml"
           : spec.family == AlgorithmFamily::kGradient  ? dir + "dgbb.yaml"
                                                        : dir + "default.yaml";
  }
  return config::load_scenario(path, {"algorithm.name=" + std::string(spec.name), "run.steps=3"});
}

TEST(AlgorithmRegistry, EveryEntryBuildsAndRunsWhereItsPlacementSays) {
  for (const auto& spec : config::algorithm_registry()) {
    SCOPED_TRACE(std::string(spec.name));
    const EstimatorBuilder* builder = estimators::find_estimator_builder(spec.name);
    ASSERT_NE(builder, nullptr);
    if (spec.family == AlgorithmFamily::kPose) {  // needs the MRCLAM dataset to run: build only
      EXPECT_EQ(builder->agent(estimators::AgentSetup{}, {})->name(), spec.name);
      continue;
    }
    const config::Scenario scenario = small_scenario(spec);
    const World world = build_world(scenario);
    const RunRecord record = run_simulation(scenario);
    ASSERT_EQ(record.metrics.size(), 3U);
    if (spec.placement == AlgorithmPlacement::kFusionCentre) {
      EXPECT_NE(make_fusion_filter(scenario, world), nullptr);
      EXPECT_TRUE(record.extra.contains("final_total_mse_m2")) << "not run by the fusion-centre runner";
    } else {
      EXPECT_EQ(builder->agent(world.setup_of(0), {})->name(), spec.name);
      EXPECT_THROW((void)make_fusion_filter(scenario, world), std::invalid_argument);
      EXPECT_FALSE(record.extra.contains("final_total_mse_m2")) << "run by the fusion-centre runner";
    }
  }
}

}  // namespace
}  // namespace swarmloc::sim
