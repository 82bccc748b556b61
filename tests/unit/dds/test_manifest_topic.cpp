// The agent manifest over DDS (dds/manifest_topic.hpp): a sample carries exactly the file's manifest, a
// hostile or garbled one is rejected with the file's error (and counted), and an agent finds its own.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "sample_manifest.hpp"
#include "swarmloc/dds/manifest_topic.hpp"

namespace swarmloc::dds {
namespace {

runtime::AgentManifest topic_manifest(AgentId id = 3, const std::string& run_id = "r-manifest") {
  return testing::sample_manifest(id, run_id);
}

const std::string kManifestYaml = "seed: 1\nworld:\n  agents: 7\n";

/// read_manifest_fields' error, or "" if the fields were accepted.
std::string field_rejection(const ManifestFields& fields) {
  try {
    (void)read_manifest_fields(fields, "sample");
  } catch (const runtime::ManifestError& error) {
    return error.what();
  }
  return "";
}

TEST(ManifestTopic, FieldsCarryExactlyTheFilesManifest) {
  for (const double std_m : {0.75, std::numeric_limits<double>::infinity()}) {
    auto m = topic_manifest();
    m.setup.initial_guess_std_m = std_m;
    m.setup.comm_radius_m = std::isinf(std_m) ? std_m : 15.5;
    const ManifestOffer back = read_manifest_fields(manifest_fields(m, kManifestYaml), "sample");
    // The file's text is exact for doubles: equal text, equal manifests bit for bit.
    EXPECT_EQ(runtime::to_json_text(back.manifest), runtime::to_json_text(m));
    EXPECT_EQ(back.manifest.setup.initial_guess_m, m.setup.initial_guess_m);
    EXPECT_EQ(back.manifest.clock.offset_s, m.clock.offset_s);
    EXPECT_EQ(back.manifest.runtime.partition_group[6], 1);
    EXPECT_EQ(back.scenario_yaml, kManifestYaml);
  }
  auto no_partition = topic_manifest();
  no_partition.runtime.partition_group.clear();
  const auto back = read_manifest_fields(manifest_fields(no_partition, kManifestYaml), "sample");
  EXPECT_TRUE(back.manifest.runtime.partition_group.empty());
}

TEST(ManifestTopic, HostileFieldsAreRejectedWithTheFieldsName) {
  const ManifestFields good = manifest_fields(topic_manifest(), kManifestYaml);
  ASSERT_EQ(field_rejection(good), "");
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  constexpr double inf = std::numeric_limits<double>::infinity();
  struct Case {
    const char* expected;  ///< a piece of the error
    void (*spoil)(ManifestFields&);
  };
  const Case cases[] = {
      {"setup.initial_guess_m must be finite", [](ManifestFields& f) { f.initial_guess_m[1] = nan; }},
      {"clock.drift_ppm must be finite", [](ManifestFields& f) { f.clock_drift_ppm = inf; }},
      {"initial_guess_std_m must be a number or +inf",
       [](ManifestFields& f) { f.initial_guess_std_m = nan; }},
      {"comm_radius_m must be a number or +inf", [](ManifestFields& f) { f.comm_radius_m = -inf; }},
      {"comm_radius_m must be > 0", [](ManifestFields& f) { f.comm_radius_m = 0.0; }},
      {"initial_guess_std_m must be >= 0", [](ManifestFields& f) { f.initial_guess_std_m = -1.0; }},
      {"neighbours holds 3",
       [](ManifestFields& f) {
         f.neighbours = {0, 3};
       }},
      {"neighbours must be sorted",
       [](ManifestFields& f) {
         f.neighbours = {2, 0};
       }},
      {"neighbours holds 7",
       [](ManifestFields& f) {
         f.neighbours = {0, 7};
       }},
      {"version must be 1", [](ManifestFields& f) { f.version = 2; }},
      {"agents must lie in", [](ManifestFields& f) { f.agent_count = 0; }},
      {"id is out of range", [](ManifestFields& f) { f.agent_id = 7; }},
      {"run_id must not be empty", [](ManifestFields& f) { f.run_id.clear(); }},
      {"loss_probability must lie in [0, 1]", [](ManifestFields& f) { f.loss_probability = 1.5; }},
      {"world_period_s must be positive", [](ManifestFields& f) { f.world_period_s = 0.0; }},
      {"groups.6 is missing", [](ManifestFields& f) { f.partition_groups.pop_back(); }},
      {"groups lists agent 3 twice",
       [](ManifestFields& f) {
         f.partition_groups.push_back({3, 0});
       }},
      {"groups.3 is out of range", [](ManifestFields& f) { f.partition_groups[0].second = 7; }},
      {"invalid agent manifest", [](ManifestFields& f) { f.run_id = "\xff\xfe"; }},  // not UTF-8
      {"scenario_yaml is empty", [](ManifestFields& f) { f.scenario_yaml.clear(); }},
  };
  for (const Case& c : cases) {
    ManifestFields hostile = good;
    c.spoil(hostile);
    const std::string error = field_rejection(hostile);
    EXPECT_NE(error.find(c.expected), std::string::npos)
        << "expected '" << c.expected << "', got '" << error << "'";
    EXPECT_EQ(error.rfind("sample: ", 0), 0U) << error;  // names its source
  }
}

TEST(ManifestTopic, SpatialSetupIsCheckedLikeTheFiles) {
  auto m = topic_manifest();
  m.setup.dimensions = 3;
  m.setup.initial_altitude_m = -1.0 / 3.0;
  const ManifestFields fields = manifest_fields(m, kManifestYaml);
  EXPECT_EQ(fields.dimensions, 3);
  EXPECT_EQ(fields.initial_altitude_m, -1.0 / 3.0);
  const ManifestOffer back = read_manifest_fields(fields, "sample");
  EXPECT_EQ(back.manifest.setup.dimensions, 3);
  EXPECT_EQ(back.manifest.setup.initial_altitude_m, -1.0 / 3.0);
  EXPECT_EQ(runtime::to_json_text(back.manifest), runtime::to_json_text(m));
  for (const int dimensions : {0, 1, 4}) {
    ManifestFields hostile = fields;
    hostile.dimensions = dimensions;
    EXPECT_NE(field_rejection(hostile).find("setup.dimensions "), std::string::npos) << dimensions;
  }
  ManifestFields hostile = fields;
  hostile.initial_altitude_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(field_rejection(hostile).find("setup.initial_altitude_m must be finite"), std::string::npos);
}

/// Random garbage in every field: accepted or a ManifestError, never anything else; what is accepted
/// obeys the file's rules (it re-reads as a file).
TEST(ManifestTopic, GarbledFieldsNeverEscapeAsAnythingButManifestError) {
  std::mt19937_64 random(20261202);
  const double specials[] = {0.0,
                             -0.0,
                             1e308,
                             -1e308,
                             std::numeric_limits<double>::quiet_NaN(),
                             std::numeric_limits<double>::infinity(),
                             5e-324,
                             1.0};
  auto number = [&](double value) { return random() % 4 == 0 ? specials[random() % 8] : value; };
  auto integer = [&](std::int64_t value) -> std::int64_t {
    return random() % 4 == 0 ? static_cast<std::int64_t>(random()) >> (random() % 64) : value;
  };
  int accepted = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    ManifestFields f = manifest_fields(topic_manifest(), kManifestYaml);
    f.agent_id = static_cast<std::int32_t>(integer(f.agent_id));
    f.agent_count = static_cast<std::int32_t>(integer(f.agent_count));
    f.version = static_cast<std::int32_t>(integer(f.version));
    for (auto& n : f.neighbours) n = static_cast<std::int32_t>(integer(n));
    if (random() % 8 == 0) f.neighbours.resize(random() % 40, static_cast<std::int32_t>(random()));
    f.initial_guess_m[0] = number(f.initial_guess_m[0]);
    f.initial_guess_std_m = number(f.initial_guess_std_m);
    f.dimensions = static_cast<std::int32_t>(integer(f.dimensions));
    f.initial_altitude_m = number(f.initial_altitude_m);
    f.clock_drift_ppm = number(f.clock_drift_ppm);
    f.loss_probability = number(f.loss_probability);
    f.world_period_s = number(f.world_period_s);
    f.partition_from_step = integer(f.partition_from_step);
    for (auto& [agent, group] : f.partition_groups) {
      agent = static_cast<std::int32_t>(integer(agent));
      group = static_cast<std::uint8_t>(integer(group));
    }
    if (random() % 8 == 0) f.run_id.push_back(static_cast<char>(random()));
    try {
      const ManifestOffer offer = read_manifest_fields(f, "garbled");
      EXPECT_NO_THROW((void)runtime::parse_manifest(runtime::to_json_text(offer.manifest), "again"));
      ++accepted;
    } catch (const runtime::ManifestError&) {
    }
  }
  EXPECT_GT(accepted, 0);  // the mutations leave some samples whole
  EXPECT_LT(accepted, 4000);
}

config::Scenario manifest_scenario(int domain, const std::string& run_id) {
  config::Scenario scenario;
  scenario.dds.domain_id = domain;
  scenario.dds.run_id = run_id;
  scenario.dds.interface = "lo";
  return scenario;
}

// Over DDS (domain 186): a hostile sample is counted and refused with its error; the orchestrator's
// replacement (keep-last 1 per agent) is then taken; each agent gets its own, also without a run id.
TEST(ManifestTopic, AgentTakesItsOwnSampleAndRefusesAHostileOne) {
  constexpr int kDomain = 186;
  const auto scenario = manifest_scenario(kDomain, "r-mt186");
  ManifestPublisher publisher(scenario, 7);
  ManifestFields hostile = manifest_fields(topic_manifest(3, "r-mt186"), kManifestYaml);
  hostile.neighbours = {0, 3, 6};  // itself
  publisher.publish_fields(hostile);

  ManifestWaitStats stats;
  try {
    (void)receive_manifest(scenario, 3, 3.0, &stats);
    ADD_FAILURE() << "a hostile manifest was accepted";
  } catch (const runtime::ManifestError& error) {
    EXPECT_NE(std::string(error.what()).find("neighbours holds 3"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("1 manifest sample(s) rejected"), std::string::npos)
        << error.what();
  }
  EXPECT_EQ(stats.rejected, 1);

  const auto honest = topic_manifest(3, "r-mt186");
  publisher.publish({honest, topic_manifest(5, "r-mt186")}, kManifestYaml);
  const ManifestOffer offer = receive_manifest(scenario, 3, 10.0, &stats);
  EXPECT_EQ(stats.rejected, 0);
  EXPECT_EQ(runtime::to_json_text(offer.manifest), runtime::to_json_text(honest));
  EXPECT_EQ(offer.scenario_yaml, kManifestYaml);

  const ManifestOffer any_run = receive_manifest(manifest_scenario(kDomain, ""), 5, 10.0);
  EXPECT_EQ(any_run.manifest.id, 5);
  EXPECT_EQ(any_run.manifest.run_id, "r-mt186");
  EXPECT_THROW((void)receive_manifest(manifest_scenario(kDomain, "r-other"), 5, 1.0), ManifestTimeout);
  EXPECT_THROW((void)receive_manifest(scenario, 4, 1.0), ManifestTimeout);  // nothing offered to agent 4
}

// Over DDS (domain 187): a planar and a 3-D agent's manifests, each exactly as the file holds it.
TEST(ManifestTopic, PlanarAndSpatialManifestsCrossTheWireExactly) {
  constexpr int kDomain = 187;
  const auto scenario = manifest_scenario(kDomain, "r-mt187");
  ManifestPublisher publisher(scenario, 7);
  const auto planar = topic_manifest(3, "r-mt187");
  auto spatial = topic_manifest(5, "r-mt187");
  spatial.setup.dimensions = 3;
  spatial.setup.initial_altitude_m = 0.1 + 0.7;  // no short decimal form
  publisher.publish({planar, spatial}, kManifestYaml);
  const ManifestOffer planar_back = receive_manifest(scenario, 3, 10.0);
  EXPECT_EQ(planar_back.manifest.setup.dimensions, 2);
  EXPECT_EQ(planar_back.manifest.setup.initial_altitude_m, 0.0);
  EXPECT_EQ(runtime::to_json_text(planar_back.manifest), runtime::to_json_text(planar));
  const ManifestOffer spatial_back = receive_manifest(scenario, 5, 10.0);
  EXPECT_EQ(spatial_back.manifest.setup.dimensions, 3);
  EXPECT_EQ(spatial_back.manifest.setup.initial_altitude_m, 0.1 + 0.7);
  EXPECT_EQ(runtime::to_json_text(spatial_back.manifest), runtime::to_json_text(spatial));
}

}  // namespace
}  // namespace swarmloc::dds
