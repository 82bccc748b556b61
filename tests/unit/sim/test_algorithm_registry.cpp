// The algorithm registry (config/algorithms.hpp) is the one table of algorithms: each entry names its
// builder (estimators/builders.hpp). Every entry has exactly one builder (an agent's estimator or the fusion
// centre's filter) that agrees with its placement, every builder serves exactly one entry, every entry is
// accepted by config, builds, and runs in the runner its placement names. The consistency rules are one
// function so that mutated copies of the table (an entry removed, a placement flipped, a builder doubled)
// can be shown to fail them.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "named_estimators.hpp"
#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/estimators/builders.hpp"
#include "swarmloc/run/fusion_centre.hpp"
#include "swarmloc/rundir/recording.hpp"
#include "swarmloc/sim/centralized_runner.hpp"
#include "swarmloc/sim/simulator.hpp"
#include "swarmloc/world/bound.hpp"

namespace swarmloc::sim {
namespace {

using config::AlgorithmFamily;
using config::AlgorithmPlacement;
using config::AlgorithmSpec;
using estimators::AgentBuilder;

/// Every agent builder estimators/builders.hpp declares.
const std::map<std::string, AgentBuilder>& agent_builders() {
  namespace b = estimators::builders;
  static const std::map<std::string, AgentBuilder> all{
      {"ieif", &b::ieif},
      {"iekf", &b::iekf},
      {"dml", &b::dml},
      {"dml_track", &b::dml_track},
      {"pose_ekf", &b::pose_ekf},
      {"pose_ieif", &b::pose_ieif},
      {"dead_reckoning", &b::dead_reckoning},
      {"jacobi", &b::jacobi},
      {"dle", &b::dle},
      {"joint_field", &b::joint_field},
      {"multipath_bp", &b::multipath_bp},
      {"dgbb", &b::dgbb},
      {"local_bb", &b::local_bb},
      {"fixed_step", &b::fixed_step},
      {"step_length", &b::step_length},
  };
  return all;
}

/// Every way the table can be inconsistent, one line each (empty: consistent).
std::vector<std::string> registry_problems(const std::vector<AlgorithmSpec>& specs) {
  std::vector<std::string> problems;
  std::set<std::string_view> names;
  std::map<AgentBuilder, int> uses;
  for (const auto& spec : specs) {
    const std::string name(spec.name);
    if (!names.insert(spec.name).second) problems.push_back(name + ": two entries");
    const bool agent = spec.build.agent != nullptr;
    const bool fusion = spec.build.fusion.has_value();
    if (agent == fusion) problems.push_back(name + ": not exactly one builder");
    if (agent) ++uses[spec.build.agent];
    const bool centre = spec.placement == AlgorithmPlacement::kFusionCentre;
    if (centre != fusion || centre == agent)
      problems.push_back(name + ": placement disagrees with its builder");
    if (centre != (spec.family == AlgorithmFamily::kCentralized))
      problems.push_back(name + ": placement disagrees with its family");
    // The fusion centre takes one range per edge and every anchor's fix (run::centralized_measurements).
    if (centre && (spec.bound.draws != config::RangeDraws::kOnePerEdge || !spec.kinds.anchor_fixes))
      problems.push_back(name + ": fusion-centre bound data is not one range per edge with fixes");
    const bool cooperative = spec.family == AlgorithmFamily::kConsensus ||
                             spec.family == AlgorithmFamily::kBp || spec.family == AlgorithmFamily::kGradient;
    if (cooperative && !spec.exchange_only)
      problems.push_back(name + ": a cooperative algorithm that does not take extra exchanges");
    if (spec.bound.model == config::BoundModel::kRanges && !spec.kinds.ranges)
      problems.push_back(name + ": range bound without ranges");
    if (spec.bound.model == config::BoundModel::kNone && spec.bound.none_reason.empty())
      problems.push_back(name + ": no bound and no reason");
  }
  for (const auto& [builder_name, builder] : agent_builders()) {
    const int count = uses.contains(builder) ? uses.at(builder) : 0;
    if (count != 1)
      problems.push_back("builders::" + builder_name + ": serves " + std::to_string(count) + " entries");
  }
  return problems;
}

std::string joined(const std::vector<std::string>& lines) {
  std::string out;
  for (const auto& line : lines) out += line + "\n";
  return out;
}

TEST(AlgorithmRegistry, EveryEntryHasExactlyOneBuilderAndEveryBuilderOneEntry) {
  EXPECT_EQ(joined(registry_problems(config::algorithm_registry())), "");
}

TEST(AlgorithmRegistry, MutantsFailTheConsistencyCheck) {
  const auto& specs = config::algorithm_registry();
  auto removed = specs;
  removed.erase(std::find_if(removed.begin(), removed.end(), [](const auto& s) { return s.name == "dgbb"; }));
  EXPECT_NE(joined(registry_problems(removed)).find("builders::dgbb: serves 0 entries"), std::string::npos);
  auto doubled = specs;
  std::find_if(doubled.begin(), doubled.end(), [](const auto& s) { return s.name == "iekf"; })->build.agent =
      &estimators::builders::ieif;
  EXPECT_NE(joined(registry_problems(doubled)).find("builders::ieif: serves 2 entries"), std::string::npos);
  auto none = specs;
  std::find_if(none.begin(), none.end(), [](const auto& s) { return s.name == "lbekf"; })->build =
      estimators::EstimatorBuilder{};
  EXPECT_NE(joined(registry_problems(none)).find("lbekf: not exactly one builder"), std::string::npos);
  auto misplaced = specs;
  std::find_if(misplaced.begin(), misplaced.end(), [](const auto& s) { return s.name == "ekf"; })->placement =
      AlgorithmPlacement::kAgent;
  EXPECT_NE(joined(registry_problems(misplaced)).find("ekf: placement disagrees"), std::string::npos);
}

TEST(AlgorithmRegistry, ConfigAcceptsExactlyTheEntries) {
  std::vector<std::string> names;
  for (const auto& spec : config::algorithm_registry()) {
    names.emplace_back(spec.name);
    EXPECT_EQ(&config::algorithm_spec(spec.name), &spec);
    EXPECT_EQ(world::bound_data(std::string(spec.name)).algorithm, spec.name);
    EXPECT_EQ(config::runs_in_fusion_centre(spec.name), spec.placement == AlgorithmPlacement::kFusionCentre)
        << spec.name;
  }
  EXPECT_EQ(world::bound_data_table().size(), names.size());
  EXPECT_EQ(config::known_algorithm_list().find("no_such"), std::string::npos);
  EXPECT_THROW((void)config::algorithm_spec("no_such"), config::ScenarioError);
  EXPECT_FALSE(config::runs_in_fusion_centre("no_such"));
  std::vector<std::string> exchange_only;
  for (const auto& spec : config::algorithm_registry())
    if (spec.exchange_only) exchange_only.emplace_back(spec.name);
  EXPECT_EQ(config::exchange_only_algorithms(), exchange_only);
  // The cooperative family, and dml and dml_track, whose step without a batch is one more sweep.
  auto expected = testing::cooperative_algorithms();
  expected.emplace_back("dml");
  expected.emplace_back("dml_track");
  std::sort(expected.begin(), expected.end());
  std::sort(exchange_only.begin(), exchange_only.end());
  EXPECT_EQ(exchange_only, expected);
}

/// A small valid scenario for `spec`: scenarios/<name>.yaml if there is one, else its family's.
config::Scenario small_scenario(const AlgorithmSpec& spec, int steps = 3,
                                const std::vector<std::string>& more = {}) {
  const std::string dir = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/";
  std::string path = dir + std::string(spec.name) + ".yaml";
  if (!std::filesystem::exists(path)) {
    path = spec.family == AlgorithmFamily::kCentralized ? dir + "ea2.yaml"
           : spec.family == AlgorithmFamily::kGradient  ? dir + "dgbb.yaml"
                                                        : dir + "ieif.yaml";
  }
  std::vector<std::string> overrides{"algorithm.name=" + std::string(spec.name),
                                     "run.steps=" + std::to_string(steps)};
  overrides.insert(overrides.end(), more.begin(), more.end());
  return config::load_scenario(path, overrides);
}

TEST(AlgorithmRegistry, EveryEntryBuildsAndRunsWhereItsPlacementSays) {
  for (const auto& spec : config::algorithm_registry()) {
    SCOPED_TRACE(std::string(spec.name));
    const estimators::EstimatorBuilder* builder = &spec.build;
    if (spec.family == AlgorithmFamily::kPose) {  // needs the MRCLAM dataset to run: build only
      EXPECT_EQ(builder->agent(estimators::AgentSetup{}, {})->name(), spec.name);
      continue;
    }
    const config::Scenario scenario = small_scenario(spec);
    const world::World world = world::build_world(scenario);
    const rundir::RunRecord record = run_simulation(scenario);
    ASSERT_EQ(record.metrics.size(), 3U);
    if (spec.placement == AlgorithmPlacement::kFusionCentre) {
      EXPECT_NE(run::make_fusion_filter(scenario, world), nullptr);
      EXPECT_TRUE(record.extra.contains("final_total_mse_m2")) << "not run by the fusion-centre runner";
    } else {
      EXPECT_EQ(builder->agent(world.setup_of(0), {})->name(), spec.name);
      EXPECT_THROW((void)run::make_fusion_filter(scenario, world), std::invalid_argument);
      EXPECT_FALSE(record.extra.contains("final_total_mse_m2")) << "run by the fusion-centre runner";
    }
  }
}

/// Collects the sample families the agents of a run receive (the simulator delivers every published
/// sample to each neighbour through the recorder, before loss).
class FamilyRecorder final : public rundir::RunRecorder {
 public:
  void begin(const config::Scenario& /*scenario*/, const world::World& /*world*/) override {}
  void world_step(std::int64_t /*step*/, const std::vector<Vec2>& /*truth*/,
                  const std::vector<estimators::MeasurementBatch>& /*batches*/) override {}
  void sample(const runtime::ReceivedSample& sample) override { families.insert(sample.message.index()); }
  std::set<std::size_t> families;
};

std::set<std::size_t> declared_families(const config::MessageFamilies& messages) {
  std::set<std::size_t> families;
  if (messages.state) families.insert(static_cast<std::size_t>(runtime::SampleFamily::kState));
  if (messages.information) families.insert(static_cast<std::size_t>(runtime::SampleFamily::kInformation));
  if (messages.consensus) families.insert(static_cast<std::size_t>(runtime::SampleFamily::kConsensus));
  if (messages.belief) families.insert(static_cast<std::size_t>(runtime::SampleFamily::kBelief));
  return families;
}

// The DDS agent creates endpoints for the declared families only and refuses to publish any other, so an
// entry must declare exactly what its agents publish. Pose entries need the MRCLAM dataset: not covered.
TEST(AlgorithmRegistry, AnEntryDeclaresExactlyTheSampleFamiliesItsAgentsPublish) {
  constexpr int kSteps = 8;  // dgbb.yaml: T = 5, so one DG-BB consensus exchange
  for (const auto& spec : config::algorithm_registry()) {
    if (spec.family == AlgorithmFamily::kPose) continue;
    SCOPED_TRACE(std::string(spec.name));
    FamilyRecorder recorder;
    SimOptions options;
    options.recorder = &recorder;
    (void)run_simulation(small_scenario(spec, kSteps), options);
    EXPECT_EQ(recorder.families, declared_families(spec.messages));
  }
}

/// Every key of one block away from its default and from the scenario files' values.
std::vector<std::string> block_changes(config::ParamBlock block) {
  switch (block) {
    case config::ParamBlock::kKalman:
      return {"algorithm.process_noise_std_m=0.05", "algorithm.initial_information=1e-3",
              "algorithm.initial_std_m=3",          "algorithm.inflate_stale=false",
              "algorithm.range_gate_chi2=9",        "algorithm.update_iterations=3"};
    case config::ParamBlock::kPose:
      return {"algorithm.initial_heading_std_rad=0.5", "algorithm.range_bearing_gate_chi2=5"};
    case config::ParamBlock::kGradient:
      return {"algorithm.consensus_rounds=2",
              "algorithm.fixed_step=0.05",
              "algorithm.step_length=4",
              "algorithm.max_step=0.5",
              "algorithm.max_move_fraction=0.3",
              "algorithm.abs_tol=1e-3",
              "algorithm.local_bb_difference=own_move"};
    case config::ParamBlock::kField:
      return {"algorithm.field_warmup_steps=2"};
    case config::ParamBlock::kMultipath:
      return {"algorithm.path_variance=with_doa", "algorithm.bp_messages=exact"};
  }
  return {};
}

/// Every estimate of the run, bit for bit.
std::string estimates_fingerprint(const rundir::RunRecord& record) {
  std::string out;
  const auto add = [&](double value) {
    std::array<char, 40> text{};
    std::snprintf(text.data(), text.size(), "%a,", value);
    out += text.data();
  };
  for (const auto& row : record.estimates) {
    const auto& estimate = row.estimate;
    out += std::to_string(row.step) + ":" + std::to_string(row.agent) + (estimate.valid ? "v" : "i");
    for (const double value : {estimate.mean_m.x(), estimate.mean_m.y(), estimate.covariance(0, 0),
                               estimate.covariance(0, 1), estimate.covariance(1, 1)})
      add(value);
    for (Eigen::Index k = 0; k < estimate.field.size(); ++k) add(estimate.field(k));
    out += ';';
  }
  return out;
}

// The blocks an entry declares are the blocks its run depends on, so the parser's "not used by" warning
// is true and a declared block is not dead. Pose entries need the MRCLAM dataset to run: not covered.
TEST(AlgorithmRegistry, AnEntryReadsExactlyTheParameterBlocksItDeclares) {
  constexpr int kSteps = 8;  // dgbb.yaml: T = 5, so one DG-BB update
  for (const auto& spec : config::algorithm_registry()) {
    if (spec.family == AlgorithmFamily::kPose) continue;
    SCOPED_TRACE(std::string(spec.name));
    const std::string base = estimates_fingerprint(run_simulation(small_scenario(spec, kSteps)));
    ASSERT_FALSE(base.empty());
    for (const auto& block : config::param_blocks()) {
      const auto changed = small_scenario(spec, kSteps, block_changes(block.block));
      EXPECT_EQ(estimates_fingerprint(run_simulation(changed)) != base, spec.blocks.reads(block.block))
          << "block " << block.name
          << (spec.blocks.reads(block.block) ? " declared, no effect" : " not declared, changes the run");
    }
  }
}

}  // namespace
}  // namespace swarmloc::sim
