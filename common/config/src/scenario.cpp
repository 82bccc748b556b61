// Scenario files: reading, walking the YAML tree against the key table, --set overrides, serialization.
#include "swarmloc/config/scenario.hpp"

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <initializer_list>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string_view>
#include <system_error>

#include "scenario_keys.hpp"
#include "swarmloc/config/algorithms.hpp"

namespace swarmloc::config {
namespace {

using detail::KeySpec;

/// Where each key's value came from, as the suffix appended to errors about it:
/// " at x.yaml:12:9" or " (from --set network.loss=1.4)".
using Sources = std::map<std::string, std::string>;

std::string at(const std::string& origin, const YAML::Mark& mark) {
  if (mark.is_null()) return " in " + origin;
  return " at " + origin + ":" + std::to_string(mark.line + 1) + ":" + std::to_string(mark.column + 1);
}

std::string join_path(const std::string& section, const std::string& name) {
  return section.empty() ? name : section + "." + name;
}

/// The error about the key at `path`: the path, the parts of the message, where the key is.
ScenarioError key_error(const std::string& path, std::initializer_list<std::string_view> parts,
                        const std::string& key_at) {
  std::string text = path;
  for (const std::string_view part : parts) text += part;
  text += key_at;
  return ScenarioError(text);
}

std::string list_keys_of(const std::string& section) {
  std::string list;
  for (const auto& child : detail::children_of(section))
    list += (list.empty() ? "" : ", ") + join_path(section, child);
  return list;
}

void apply_map(Scenario& scenario, const YAML::Node& map, const std::string& section,
               const std::string& origin, Sources& sources) {
  std::set<std::string> seen;
  for (const auto& entry : map) {
    const YAML::Node& key_node = entry.first;
    const YAML::Node& value = entry.second;
    const std::string key_at = at(origin, key_node.Mark());
    if (!key_node.IsScalar()) {
      throw ScenarioError((section.empty() ? origin : section) + ": keys must be plain names, got " +
                          detail::describe(key_node) + key_at);
    }
    const std::string& name = key_node.Scalar();
    const std::string path = join_path(section, name);
    if (!seen.insert(name).second) throw key_error(path, {": duplicate key"}, key_at);
    if (name.find('.') != std::string::npos) {
      throw key_error(path, {": dotted names are for --set; in a file nest each part as a map"}, key_at);
    }
    if (const KeySpec* key = detail::find_key(path)) {
      const std::string value_at = value.Mark().is_null() ? key_at : at(origin, value.Mark());
      try {
        key->read(scenario, value);
      } catch (const ScenarioError& error) {
        throw ScenarioError(error.what() + value_at);
      }
      sources[path] = value_at;
    } else if (detail::is_section(path)) {
      if (value.IsNull()) continue;  // "qos:" with nothing under it keeps every default
      if (!value.IsMap()) {
        throw key_error(
            path, {": expected a map with keys ", list_keys_of(path), ", got ", detail::describe(value)},
            key_at);
      }
      apply_map(scenario, value, path, origin, sources);
    } else {
      throw key_error(path, {": unknown key", detail::suggestion_for(path)}, key_at);
    }
  }
}

void apply_override(Scenario& scenario, const std::string& text, Sources& sources) {
  const auto equals = text.find('=');
  const auto first = equals == std::string::npos ? std::string::npos : text.find_first_not_of(" \t");
  if (equals == std::string::npos || first >= equals) {
    throw ScenarioError("--set '" + text + "': expected key.path=value, e.g. --set world.agents=40");
  }
  const std::string path = text.substr(first, text.find_last_not_of(" \t", equals - 1) - first + 1);
  const std::string value = text.substr(equals + 1);
  const std::string from = " (from --set " + text + ")";
  const KeySpec* key = detail::find_key(path);
  if (key == nullptr) {
    if (detail::is_section(path)) {
      throw ScenarioError(path + ": is a section, not a key; set one of " + list_keys_of(path) + from);
    }
    throw ScenarioError(path + ": unknown key" + detail::suggestion_for(path) + from);
  }
  YAML::Node node;
  try {
    node = YAML::Load(value);
  } catch (const YAML::Exception& error) {
    throw ScenarioError(path + ": cannot read '" + value + "' as a YAML value (" + error.msg + ")" + from);
  }
  try {
    key->read(scenario, node);
  } catch (const ScenarioError& error) {
    throw ScenarioError(error.what() + from);
  }
  sources[path] = from;
}

/// Counts the YAML documents in `text` with the event parser, building no nodes. yaml-cpp 0.7 (Debian
/// bookworm) never consumes a ',' outside a flow collection (e.g. the text ","): every
/// HandleNextDocument call then "parses" another null document at the same place, so LoadAll appends
/// documents until memory runs out (jbeder/yaml-cpp#1040, fixed upstream by PR #1319; found here by the
/// scenario fuzz target, tests/fuzz). A document that starts where the previous one started means the
/// parser is stuck: reported as a syntax error at that place.
class DocumentCounter : public YAML::EventHandler {
 public:
  std::size_t count(const std::string& text, const std::string& subject) {
    std::istringstream in(text);
    YAML::Parser parser(in);
    while (parser.HandleNextDocument(*this)) {
      if (starts_.size() >= 2 && starts_.back().pos == starts_[starts_.size() - 2].pos) {
        const YAML::Mark& mark = starts_.back();
        throw ScenarioError(subject + ": YAML syntax error at line " + std::to_string(mark.line + 1) +
                            ", column " + std::to_string(mark.column + 1) + ": unexpected '" +
                            text.substr(static_cast<std::size_t>(mark.pos), 1) + "'");
      }
    }
    return starts_.size();
  }
  void OnDocumentStart(const YAML::Mark& mark) override { starts_.push_back(mark); }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& /*mark*/, YAML::anchor_t /*anchor*/) override {}
  void OnAlias(const YAML::Mark& /*mark*/, YAML::anchor_t /*anchor*/) override {}
  void OnScalar(const YAML::Mark& /*mark*/, const std::string& /*tag*/, YAML::anchor_t /*anchor*/,
                const std::string& /*value*/) override {}
  void OnSequenceStart(const YAML::Mark& /*mark*/, const std::string& /*tag*/, YAML::anchor_t /*anchor*/,
                       YAML::EmitterStyle::value /*style*/) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark& /*mark*/, const std::string& /*tag*/, YAML::anchor_t /*anchor*/,
                  YAML::EmitterStyle::value /*style*/) override {}
  void OnMapEnd() override {}

 private:
  std::vector<YAML::Mark> starts_;
};

/// load_scenario's warnings: algorithm keys of a block the algorithm does not read, set by --set, or in
/// the file to other than the default (a file listing every key at its default is a template).
void add_unused_key_warnings(const Scenario& scenario, const Sources& sources,
                             std::vector<std::string>& warnings) {
  const AlgorithmSpec& spec = algorithm_spec(scenario.algorithm.name);
  const Scenario defaults;
  for (const auto& key : detail::key_specs()) {
    if (!key.block || spec.blocks.reads(*key.block)) continue;
    const auto source = sources.find(key.path);
    if (source == sources.end()) continue;
    const bool from_set = source->second.starts_with(" (from --set ");
    if (!from_set && key.write(scenario) == key.write(defaults)) continue;
    warnings.push_back(key.path + ": a " + std::string(param_block_spec(*key.block).name) +
                       " key, not used by " + scenario.algorithm.name + " (read by " +
                       algorithms_reading(*key.block) + ")" + source->second);
  }
}

/// Parses, resolves, overrides and validates. `subject` opens file-level errors ("scenario file 'x'");
/// `origin` prefixes line:column locations; `base_dir` resolves a relative world.positions_file
/// and world.data_dir.
Scenario parse(const std::string& yaml_text, const std::vector<std::string>& overrides,
               const std::string& origin, const std::string& subject,
               const std::optional<std::filesystem::path>& base_dir, std::vector<std::string>* warnings) {
  std::vector<YAML::Node> documents;
  try {
    // Count first (cheap, and safe from the LoadAll loop above), then build the nodes.
    if (DocumentCounter().count(yaml_text, subject) > 0) documents = YAML::LoadAll(yaml_text);
  } catch (const YAML::Exception& error) {
    std::string where;
    if (!error.mark.is_null()) {
      where = " at line " + std::to_string(error.mark.line + 1) + ", column " +
              std::to_string(error.mark.column + 1);
    }
    throw ScenarioError(subject + ": YAML syntax error" + where + ": " + error.msg);
  }
  if (documents.size() > 1) {
    throw ScenarioError(subject + ": expected one YAML document, found " + std::to_string(documents.size()));
  }

  Scenario scenario;
  Sources sources;
  if (!documents.empty() && !documents.front().IsNull()) {
    const YAML::Node& root = documents.front();
    if (!root.IsMap()) {
      throw ScenarioError(subject + ": expected a map of scenario keys at the top level, got " +
                          detail::describe(root));
    }
    apply_map(scenario, root, "", origin, sources);
  }

  // A relative positions file in a scenario file means "next to the scenario file". Made absolute so the
  // run directory's scenario.yaml still points at it.
  for (auto* path : {&scenario.world.positions_file, &scenario.world.data_dir}) {
    if (base_dir && !path->empty() && std::filesystem::path(*path).is_relative()) {
      std::error_code error;
      auto resolved = std::filesystem::absolute(*base_dir / *path, error);
      if (error) resolved = *base_dir / *path;
      *path = resolved.lexically_normal().string();
    }
  }

  for (const auto& text : overrides) apply_override(scenario, text, sources);

  try {
    validate(scenario);
  } catch (const ScenarioError& error) {
    const std::string message = error.what();
    const auto source = sources.find(message.substr(0, message.find(": ")));
    if (source == sources.end()) throw;
    throw ScenarioError(message + source->second);
  }
  if (warnings != nullptr) add_unused_key_warnings(scenario, sources, *warnings);
  return scenario;
}

std::string read_file(const std::string& path) {
  const auto cannot_read = [&](int error) {
    return ScenarioError("scenario file '" + path + "': cannot be read (" +
                         std::generic_category().message(error) + ")");
  };
  errno = 0;
  const std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!file) throw cannot_read(errno != 0 ? errno : EIO);
  std::string text;
  std::array<char, 65536> buffer{};
  std::size_t count = 0;
  while ((count = std::fread(buffer.data(), 1, buffer.size(), file.get())) > 0)
    text.append(buffer.data(), count);
  if (std::ferror(file.get()) != 0) throw cannot_read(errno != 0 ? errno : EIO);
  return text;
}

}  // namespace

Scenario load_scenario(const std::string& path, const std::vector<std::string>& overrides,
                       std::vector<std::string>* warnings) {
  const std::string text = read_file(path);
  return parse(text, overrides, path, "scenario file '" + path + "'",
               std::filesystem::path(path).parent_path(), warnings);
}

Scenario parse_scenario(const std::string& yaml_text, const std::vector<std::string>& overrides,
                        const std::string& origin, std::vector<std::string>* warnings) {
  return parse(yaml_text, overrides, origin, origin, std::nullopt, warnings);
}

std::string to_yaml(const Scenario& scenario) {
  std::string out;
  std::vector<std::string> open;  // the sections the previous key was in
  for (const auto& key : detail::key_specs()) {
    std::vector<std::string> parts;
    for (std::size_t begin = 0;;) {
      const auto dot = key.path.find('.', begin);
      parts.push_back(key.path.substr(begin, dot - begin));
      if (dot == std::string::npos) break;
      begin = dot + 1;
    }
    const std::size_t depth = parts.size() - 1;
    std::size_t common = 0;
    while (common < open.size() && common < depth && open[common] == parts[common]) ++common;
    open.resize(common);
    for (std::size_t level = common; level < depth; ++level) {
      out += std::string(2 * level, ' ') + parts[level] + ":\n";
      open.push_back(parts[level]);
    }
    out += std::string(2 * depth, ' ') + parts.back() + ": " + key.write(scenario) + "\n";
  }
  return out;
}

namespace {

std::uint64_t fnv1a(const std::string& text) {
  std::uint64_t hash = 14695981039346656037ULL;
  for (const char c : text) {
    hash ^= static_cast<unsigned char>(c);
    hash *= 1099511628211ULL;
  }
  return hash;
}

}  // namespace

std::uint64_t scenario_hash(const Scenario& scenario) {
  Scenario hashed = scenario;
  hashed.dds.run_id.clear();
  return fnv1a(to_yaml(hashed));
}

std::uint64_t results_hash(const Scenario& scenario) {
  Scenario hashed = scenario;
  hashed.name.clear();
  hashed.dds = Scenario::Dds{};
  return fnv1a(to_yaml(hashed));
}

bool valid_run_id(const std::string& run_id) {
  if (run_id.empty() || run_id.size() > 32) return false;
  return std::all_of(run_id.begin(), run_id.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
  });
}

const std::vector<std::string>& known_keys() {
  static const std::vector<std::string> keys = [] {
    std::vector<std::string> paths;
    for (const auto& key : detail::key_specs()) paths.push_back(key.path);
    return paths;
  }();
  return keys;
}

}  // namespace swarmloc::config
