#pragma once
// Private to config/: the table of every scenario key (path, how to read it from a YAML node, how to write
// it back as a YAML scalar) and the scalar codecs behind it. The table is the single source of truth for
// parsing, overrides, to_yaml and known_keys, so a key cannot be parseable yet missing from the output.
#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/config/scenario.hpp"

namespace swarmloc::config::detail {

struct KeySpec {
  std::string path;  ///< canonical dotted path, e.g. "world.agents"
  /// Decodes `node` into the scenario; throws ScenarioError "path: expected …, got …".
  std::function<void(Scenario&, const YAML::Node&)> read;
  /// The current value as a YAML scalar (round-trips through `read`).
  std::function<std::string(const Scenario&)> write;
  /// algorithm.* knobs: the parameter block the key lives in (algorithm.fixed_step -> gradient).
  std::optional<ParamBlock> block;
};

/// Every key, in document order (the order of to_yaml and known_keys).
const std::vector<KeySpec>& key_specs();

/// The key with this exact path, or nullptr.
const KeySpec* find_key(std::string_view path);

/// True when `path` is a map of keys ("world", "qos", "qos.state"); "" is the document root.
bool is_section(std::string_view path);

/// The direct children names of a section ("world" -> {"agents", "anchors", …}).
std::vector<std::string> children_of(std::string_view section);

/// " (did you mean world.agents?)" for a misspelt `path`, or "" when nothing is close.
std::string suggestion_for(std::string_view path);

/// How a node reads in an error message: "'abc'", "a map", "a list", "an empty value".
std::string describe(const YAML::Node& node);

/// Shortest text that parses back to exactly `value`: plain decimals for 1e-4 <= |value| < 1e15
/// ("1.4", "-1", "100000"), exponent form otherwise ("1e-06"), "nan", "inf".
std::string format_number(double value);

/// Each parameter block's key ranges (validate.cpp), the validators of the registry's block table
/// (algorithms.cpp). Throw ScenarioError naming the key.
void validate_kalman_params(const Scenario& scenario);
void validate_pose_params(const Scenario& scenario);
void validate_gradient_params(const Scenario& scenario);
void validate_field_params(const Scenario& scenario);
void validate_multipath_params(const Scenario& scenario);

/// Levenshtein distance with adjacent transpositions (optimal string alignment).
std::size_t edit_distance(std::string_view a, std::string_view b);

}  // namespace swarmloc::config::detail
