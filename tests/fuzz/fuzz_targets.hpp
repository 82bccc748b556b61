#pragma once
// Seeded random-mutation fuzzing (libFuzzer is not available with g++): the DDS sample decoders
// (common/dds/src/convert.cpp, IDL struct -> swarmloc message) and the scenario parser
// (config::parse_scenario). Each target draws `inputs` inputs from `seed`, mutates valid inputs, runs the
// code under test and checks its contract; any violation is recorded (the first few with the input
// index, so `--seed S --first I` reproduces it). Crashes and sanitizer reports abort the process.
// The state and batch targets feed sessions of 64 consecutive inputs into one AgentRuntime (to reach
// the duplicate / reordered / mailbox paths), so reproduce those from the session start,
// `--first I - I % 64`.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace swarmloc::fuzz {

struct FuzzResult {
  std::string target;
  std::uint64_t inputs = 0;
  std::uint64_t accepted = 0;  ///< well-formed and passed validation (decoders) / parsed (scenario)
  std::uint64_t rejected = 0;  ///< marked not well-formed, rejected by the runtime, or ScenarioError
  std::uint64_t violations = 0;
  std::vector<std::string> failures;  ///< the first few violations, with the input index
  /// How often the inputs reached a named outcome the totals cannot show (state: its 3-D samples accepted,
  /// malformed by their z part, refused for it by reason; samples with cavities accepted, malformed by them,
  /// refused for them by reason), so a test can tell a path is exercised at all.
  std::map<std::string, std::uint64_t> reached;
};

/// Names of the targets: state, information, consensus, belief, batch, estimate, control, scenario.
const std::vector<std::string>& target_names();

/// Runs `inputs` inputs of one target. Input i depends only on (seed, target, i).
FuzzResult run_target(const std::string& target, std::uint64_t seed, std::uint64_t inputs,
                      std::uint64_t first = 0);

/// The scenario target's input i: YAML text and --set overrides (to reproduce a reported input).
struct ScenarioInput {
  std::string text;
  std::vector<std::string> overrides;
};
ScenarioInput scenario_input(std::uint64_t seed, std::uint64_t i);

/// One hand-made 3-D State sample (spatial_state_cases), as the decoder and a runtime took it.
struct SpatialStateCase {
  std::string name;
  bool well_formed = false;  ///< the decoder's verdict
  bool accepted = false;     ///< the runtime's verdict
  std::string reason;  ///< the one reject reason the runtime counted (runtime::to_string); "" if accepted
  /// decoded: z, var(z), cross, every edge's peer z and every cavity (its offset z included) equal the
  /// wire's, bit for bit
  bool z_intact = false;
};

/// Valid and hostile 3-D State samples built by hand (sequence lengths above _maximum, without a buffer,
/// absurd, disagreeing with the edge summaries or the cavities; non-finite, absurd and non-PSD z parts and
/// cavities), each decoded and
/// fed from neighbour 1 with a fresh seq to one planar IEIF runtime.
std::vector<SpatialStateCase> spatial_state_cases();

}  // namespace swarmloc::fuzz
