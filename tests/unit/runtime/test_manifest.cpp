// AgentManifest: what one agent may know, written by the orchestrator and read by the agent process.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>

#include "process_helpers.hpp"
#include "sample_manifest.hpp"
#include "swarmloc/runtime/manifest.hpp"

namespace swarmloc::runtime {
namespace {

AgentManifest sample_manifest() { return testing::sample_manifest(); }

nlohmann::json sample_json() { return nlohmann::json::parse(to_json_text(sample_manifest())); }

/// parse_manifest's error for `document`, or "" if it parsed.
std::string rejection(const std::string& text) {
  try {
    (void)parse_manifest(text, "bad.json");
  } catch (const ManifestError& error) {
    return error.what();
  }
  return "";
}

TEST(AgentManifest, RoundTripsEveryFieldExactly) {
  const AgentManifest m = sample_manifest();
  const AgentManifest back = parse_manifest(to_json_text(m), "memory");
  EXPECT_EQ(back.id, m.id);
  EXPECT_EQ(back.agent_count, m.agent_count);
  EXPECT_EQ(back.setup.id, m.id);
  EXPECT_EQ(back.setup.anchor, m.setup.anchor);
  EXPECT_EQ(back.setup.initial_guess_m, m.setup.initial_guess_m);  // bit for bit
  EXPECT_EQ(back.setup.initial_heading_rad, m.setup.initial_heading_rad);
  EXPECT_EQ(back.setup.initial_guess_std_m, m.setup.initial_guess_std_m);
  EXPECT_EQ(back.neighbours, m.neighbours);
  EXPECT_EQ(back.clock.offset_s, m.clock.offset_s);
  EXPECT_EQ(back.clock.drift_ppm, m.clock.drift_ppm);
  EXPECT_EQ(back.runtime.seed, m.runtime.seed);
  EXPECT_EQ(back.runtime.loss.loss_probability, m.runtime.loss.loss_probability);
  EXPECT_EQ(back.runtime.loss.burst_mean_length, m.runtime.loss.burst_mean_length);
  EXPECT_EQ(back.runtime.absurd_position_bound_m, m.runtime.absurd_position_bound_m);
  EXPECT_EQ(back.runtime.absurd_variance_m2, m.runtime.absurd_variance_m2);
  EXPECT_EQ(back.runtime.world_period_s, m.runtime.world_period_s);
  EXPECT_EQ(back.runtime.partition_from, 5);
  EXPECT_EQ(back.runtime.partition_to, 9);
  EXPECT_EQ(back.results_hash, m.results_hash);
  EXPECT_EQ(back.run_id, m.run_id);
}

TEST(AgentManifest, HoldsOnlyItsOwnAndItsNeighboursPartitionSides) {
  const auto groups = sample_json()["runtime"]["partition"]["groups"];
  EXPECT_EQ(groups.size(), 4U);  // agent 3 and neighbours 0, 2, 6: nothing about agents 1, 4, 5
  EXPECT_FALSE(groups.contains("1"));
  const AgentManifest back = parse_manifest(to_json_text(sample_manifest()), "memory");
  ASSERT_EQ(back.runtime.partition_group.size(), 7U);
  for (const AgentId agent : {0, 2, 3, 6}) {
    EXPECT_EQ(back.runtime.partition_group[static_cast<std::size_t>(agent)],
              sample_manifest().runtime.partition_group[static_cast<std::size_t>(agent)]);
  }
}

TEST(AgentManifest, UnknownInitialGuessStdIsNullAndRoundTripsAsInfinity) {
  AgentManifest m = sample_manifest();
  m.setup.initial_guess_std_m = std::numeric_limits<double>::infinity();
  m.runtime.partition_group.clear();
  const auto json = nlohmann::json::parse(to_json_text(m));
  EXPECT_TRUE(json["setup"]["initial_guess_std_m"].is_null());
  EXPECT_FALSE(json["runtime"].contains("partition"));
  const AgentManifest back = parse_manifest(to_json_text(m), "memory");
  EXPECT_TRUE(std::isinf(back.setup.initial_guess_std_m));
  EXPECT_TRUE(back.runtime.partition_group.empty());
}

TEST(AgentManifest, PlanarSetupWritesNoDimensionsAndReadsAsPlanar) {
  const auto json = sample_json();
  EXPECT_FALSE(json["setup"].contains("dimensions"));  // planar manifests as before the 3-D fields
  EXPECT_FALSE(json["setup"].contains("initial_altitude_m"));
  const AgentManifest back = parse_manifest(json.dump(), "memory");
  EXPECT_EQ(back.setup.dimensions, 2);
  EXPECT_EQ(back.setup.initial_altitude_m, 0.0);
}

TEST(AgentManifest, SpatialSetupRoundTripsExactly) {
  AgentManifest m = sample_manifest();
  m.setup.dimensions = 3;
  m.setup.initial_altitude_m = 2.0 / 3.0;
  const auto json = nlohmann::json::parse(to_json_text(m));
  EXPECT_EQ(json["setup"]["dimensions"], 3);
  const AgentManifest back = parse_manifest(to_json_text(m), "memory");
  EXPECT_EQ(back.setup.dimensions, 3);
  EXPECT_EQ(back.setup.initial_altitude_m, 2.0 / 3.0);  // bit for bit
  EXPECT_EQ(back.setup.initial_guess_m, m.setup.initial_guess_m);
  EXPECT_EQ(to_json_text(back), to_json_text(m));
}

TEST(AgentManifest, FileRoundTripAndPathNaming) {
  const auto dir = swarmloc::testing::fresh_directory("manifest-file");
  const auto path = manifest_path(dir, 7);
  EXPECT_EQ(path, dir / "manifests" / "agent_007.json");
  write_manifest(path, sample_manifest());
  EXPECT_EQ(load_manifest(path).neighbours, sample_manifest().neighbours);
}

TEST(AgentManifest, RejectsWhatIsNotAManifest) {
  EXPECT_NE(rejection(""), "");
  EXPECT_NE(rejection("{\"format\": \"swarmloc-agent-manifest\""), "");  // cut short
  EXPECT_NE(rejection("[1, 2, 3]"), "");
  EXPECT_NE(rejection("null"), "");
  EXPECT_EQ(rejection(to_json_text(sample_manifest())), "");
}

/// Each mutation of a valid manifest must be refused with a message naming `field`.
void expect_rejected(const std::function<void(nlohmann::json&)>& mutate, const std::string& field) {
  nlohmann::json document = sample_json();
  mutate(document);
  const std::string error = rejection(document.dump());
  EXPECT_NE(error.find(field), std::string::npos)
      << "expected an error naming " << field << ", got: " << error;
  EXPECT_NE(error.find("bad.json"), std::string::npos) << error;
}

TEST(AgentManifest, RejectsInvalidFieldsNamingThem) {
  expect_rejected([](auto& j) { j["format"] = "something-else"; }, "format");
  expect_rejected([](auto& j) { j["version"] = 99; }, "version");
  expect_rejected([](auto& j) { j.erase("id"); }, "id");
  expect_rejected([](auto& j) { j["id"] = 7; }, "id");  // == agents
  expect_rejected([](auto& j) { j["id"] = -1; }, "id");
  expect_rejected([](auto& j) { j["id"] = "3"; }, "id");
  expect_rejected([](auto& j) { j["agents"] = 0; }, "agents");
  expect_rejected([](auto& j) { j["agents"] = 18446744073709551615ULL; }, "agents");
  expect_rejected([](auto& j) { j["run_id"] = ""; }, "run_id");
  expect_rejected([](auto& j) { j["results_hash"] = "xyz"; }, "results_hash");
  expect_rejected([](auto& j) { j["neighbours"] = {0, 3}; }, "neighbours");  // itself
  expect_rejected([](auto& j) { j["neighbours"] = {0, 9}; }, "neighbours");  // not in the network
  expect_rejected([](auto& j) { j["neighbours"] = {2, 0}; }, "neighbours");  // unsorted
  expect_rejected([](auto& j) { j["neighbours"] = {0, 0}; }, "neighbours");  // repeated
  expect_rejected([](auto& j) { j["neighbours"] = "0,2"; }, "neighbours");
  expect_rejected([](auto& j) { j["setup"]["initial_guess_m"] = {1.0}; }, "setup.initial_guess_m");
  expect_rejected([](auto& j) { j["setup"]["initial_guess_std_m"] = -1.0; }, "setup.initial_guess_std_m");
  expect_rejected([](auto& j) { j["setup"].erase("anchor"); }, "setup.anchor");
  expect_rejected([](auto& j) { j["clock"]["drift_ppm"] = 2e6; }, "clock.drift_ppm");
  expect_rejected([](auto& j) { j["clock"]["offset_s"] = nullptr; }, "clock.offset_s");
  expect_rejected([](auto& j) { j["runtime"]["loss_probability"] = 1.5; }, "runtime.loss_probability");
  expect_rejected([](auto& j) { j["runtime"]["world_period_s"] = 0.0; }, "runtime.world_period_s");
  expect_rejected([](auto& j) { j["runtime"]["seed"] = 12; }, "runtime.seed");
  expect_rejected([](auto& j) { j["runtime"]["partition"]["groups"].erase("6"); },
                  "runtime.partition.groups.6");
  expect_rejected([](auto& j) { j["runtime"]["partition"]["groups"]["0"] = 2; },
                  "runtime.partition.groups.0");
}

TEST(AgentManifest, RejectsABadSpatialSetupNamingIt) {
  expect_rejected([](auto& j) { j["setup"]["dimensions"] = 4; }, "setup.dimensions");
  expect_rejected([](auto& j) { j["setup"]["dimensions"] = 1; }, "setup.dimensions");
  expect_rejected([](auto& j) { j["setup"]["dimensions"] = "3"; }, "setup.dimensions");
  expect_rejected([](auto& j) { j["setup"]["initial_altitude_m"] = nullptr; }, "setup.initial_altitude_m");
  expect_rejected([](auto& j) { j["setup"]["initial_altitude_m"] = "1.5"; }, "setup.initial_altitude_m");
}

TEST(AgentManifest, MissingOrHugeFileIsAManifestError) {
  const auto dir = swarmloc::testing::fresh_directory("manifest-missing");
  EXPECT_THROW((void)load_manifest(dir / "nope.json"), ManifestError);
  const auto big = dir / "big.json";
  std::filesystem::resize_file((std::ofstream(big), big), 65u << 20);
  EXPECT_THROW((void)load_manifest(big), ManifestError);
}

}  // namespace
}  // namespace swarmloc::runtime
