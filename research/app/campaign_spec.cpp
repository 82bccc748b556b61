#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <set>

#include "campaign_internal.hpp"
#include "swarmloc/config/scenario.hpp"

namespace swarmloc::research {
namespace campaign_detail {
namespace {

/// Every error names the spec file and the key path inside it (exit code 2, like a bad scenario).
class SpecReader {
 public:
  explicit SpecReader(std::string origin) : origin_(std::move(origin)) {}

  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    throw config::ScenarioError("campaign spec " + origin_ + ": " + key + ": " + what);
  }

  void require_keys(const YAML::Node& map, const std::string& path,
                    const std::set<std::string>& allowed) const {
    if (!map.IsMap()) fail(path.empty() ? "(top level)" : path, "must be a map");
    for (const auto& entry : map) {
      const auto key = entry.first.as<std::string>();
      if (allowed.count(key) == 0) {
        std::string list;
        for (const auto& name : allowed) list += (list.empty() ? "" : ", ") + name;
        fail(join(path, key), "unknown key (expected one of: " + list + ")");
      }
    }
  }

  std::string scalar(const YAML::Node& node, const std::string& path) const {
    if (!node.IsScalar() || node.Scalar().empty()) fail(path, "must be a non-empty scalar");
    return node.Scalar();
  }

  /// A map of scenario keys to scalar values, as "key=value" overrides (key checked against the
  /// scenario's key list so a typo is named here rather than deep inside a cell).
  std::vector<std::string> overrides(const YAML::Node& node, const std::string& path) const {
    std::vector<std::string> out;
    if (!node || node.IsNull()) return out;
    if (!node.IsMap()) fail(path, "must be a map of scenario keys to values, e.g. {run.steps: 100}");
    const auto& known = config::known_keys();
    for (const auto& entry : node) {
      const auto key = entry.first.as<std::string>();
      if (std::find(known.begin(), known.end(), key) == known.end()) {
        fail(join(path, key), "unknown scenario key (see docs/scenario.md or `swarmloc run --help`)");
      }
      out.push_back(key + "=" + scalar(entry.second, join(path, key)));
    }
    return out;
  }

  std::vector<std::uint64_t> seeds(const YAML::Node& node, const std::string& path) const {
    std::vector<std::uint64_t> out;
    try {
      if (node.IsScalar()) {
        const int count = node.as<int>();
        if (count < 1 || count > 1000) fail(path, "a seed count must be in [1, 1000]");
        for (int k = 1; k <= count; ++k) out.push_back(static_cast<std::uint64_t>(k));
      } else if (node.IsSequence() && node.size() > 0) {
        for (const auto& seed : node) out.push_back(seed.as<std::uint64_t>());
      } else {
        fail(path, "must be a seed count or a non-empty list of seeds");
      }
    } catch (const YAML::BadConversion&) {
      fail(path, "must be a seed count or a non-empty list of non-negative integers");
    }
    return out;
  }

  static std::string join(const std::string& path, const std::string& key) {
    return path.empty() ? key : path + "." + key;
  }

 private:
  std::string origin_;
};

std::vector<std::string> parse_modes(const std::string& mode, const SpecReader& reader,
                                     const std::string& path) {
  if (mode == "sim") return {"sim"};
  if (mode == "dds") return {"dds"};
  if (mode == "both") return {"sim", "dds"};
  reader.fail(path, "'" + mode + "' is not one of sim, dds, both");
}

/// name, mode, seeds, dds_seeds, threads and the common overrides.
void read_top_level(const YAML::Node& root, const SpecReader& reader, CampaignSpec& spec) {
  if (root["name"]) spec.name = reader.scalar(root["name"], "name");
  if (root["mode"]) spec.modes = parse_modes(reader.scalar(root["mode"], "mode"), reader, "mode");
  if (root["seeds"]) spec.seeds = reader.seeds(root["seeds"], "seeds");
  if (root["dds_seeds"]) spec.dds_seeds = reader.seeds(root["dds_seeds"], "dds_seeds");
  if (root["threads"]) {
    try {
      spec.threads = root["threads"].as<int>();
    } catch (const YAML::BadConversion&) {
      reader.fail("threads", "must be an integer");
    }
    if (spec.threads < 0 || spec.threads > 1024)
      reader.fail("threads", "must be in [0, 1024] (0 = every core)");
  }
  spec.overrides = reader.overrides(root["overrides"], "overrides");
}

void read_algorithms(const YAML::Node& root, const SpecReader& reader, const std::filesystem::path& base,
                     CampaignSpec& spec) {
  const auto algorithms = root["algorithms"];
  if (!algorithms || !algorithms.IsSequence() || algorithms.size() == 0) {
    reader.fail("algorithms", "must be a non-empty list of {label, scenario, overrides}");
  }
  for (std::size_t k = 0; k < algorithms.size(); ++k) {
    const std::string where = "algorithms[" + std::to_string(k) + "]";
    const auto node = algorithms[k];
    reader.require_keys(node, where, {"label", "scenario", "overrides"});
    if (!node["label"]) reader.fail(where + ".label", "is required");
    if (!node["scenario"]) reader.fail(where + ".scenario", "is required");
    CampaignSpec::Algorithm algorithm;
    algorithm.label = reader.scalar(node["label"], where + ".label");
    algorithm.scenario = reader.scalar(node["scenario"], where + ".scenario");
    if (algorithm.scenario.is_relative()) algorithm.scenario = (base / algorithm.scenario).lexically_normal();
    if (!std::filesystem::exists(algorithm.scenario)) {
      reader.fail(where + ".scenario", "no such file: " + algorithm.scenario.string());
    }
    algorithm.overrides = reader.overrides(node["overrides"], where + ".overrides");
    for (const auto& other : spec.algorithms) {
      if (other.label == algorithm.label)
        reader.fail(where + ".label", "'" + algorithm.label + "' is used twice");
    }
    spec.algorithms.push_back(algorithm);
  }
}

void read_sweep(const YAML::Node& root, const SpecReader& reader, CampaignSpec& spec) {
  const auto sweep = root["sweep"];
  if (!sweep) reader.fail("sweep", "is required: {key: SCENARIO.KEY, values: [ ... ]}");
  reader.require_keys(sweep, "sweep", {"key", "values"});
  if (!sweep["key"]) reader.fail("sweep.key", "is required");
  spec.swept_key = reader.scalar(sweep["key"], "sweep.key");
  const auto& known = config::known_keys();
  if (std::find(known.begin(), known.end(), spec.swept_key) == known.end() || spec.swept_key == "seed") {
    reader.fail("sweep.key",
                "'" + spec.swept_key + "' is not a scenario key that can be swept (see docs/scenario.md)");
  }
  const auto values = sweep["values"];
  if (!values || !values.IsSequence() || values.size() == 0)
    reader.fail("sweep.values", "must be a non-empty list");
  for (std::size_t k = 0; k < values.size(); ++k) {
    spec.swept_values.push_back(reader.scalar(values[k], "sweep.values[" + std::to_string(k) + "]"));
  }
}

void read_variants(const YAML::Node& root, const SpecReader& reader, CampaignSpec& spec) {
  if (const auto variants = root["variants"]) {
    if (!variants.IsSequence() || variants.size() == 0) {
      reader.fail("variants", "must be a non-empty list of {label, overrides}");
    }
    for (std::size_t k = 0; k < variants.size(); ++k) {
      const std::string where = "variants[" + std::to_string(k) + "]";
      reader.require_keys(variants[k], where, {"label", "overrides"});
      if (!variants[k]["label"]) reader.fail(where + ".label", "is required");
      CampaignSpec::Variant variant{reader.scalar(variants[k]["label"], where + ".label"),
                                    reader.overrides(variants[k]["overrides"], where + ".overrides")};
      for (const auto& other : spec.variants) {
        if (other.label == variant.label)
          reader.fail(where + ".label", "'" + variant.label + "' is used twice");
      }
      spec.variants.push_back(variant);
    }
  } else {
    spec.variants.push_back({"-", {}});
  }
}

void read_check(const YAML::Node& root, const SpecReader& reader, CampaignSpec& spec) {
  if (const auto check = root["check"]) {
    reader.require_keys(check, "check", {"value", "max_ratio"});
    if (!check["value"]) reader.fail("check.value", "is required");
    spec.check_value = reader.scalar(check["value"], "check.value");
    if (std::find(spec.swept_values.begin(), spec.swept_values.end(), *spec.check_value) ==
        spec.swept_values.end()) {
      reader.fail("check.value", "'" + *spec.check_value + "' is not one of sweep.values");
    }
    if (check["max_ratio"]) {
      try {
        spec.check_max_ratio = check["max_ratio"].as<double>();
      } catch (const YAML::BadConversion&) {
        reader.fail("check.max_ratio", "must be a number");
      }
      if (!(spec.check_max_ratio > 0.0)) reader.fail("check.max_ratio", "must be > 0");
    }
  }
}

/// Every cell's scenario must load (the scenario loader names the offending key and value).
void check_every_cell_loads(const CampaignSpec& spec, const std::filesystem::path& path) {
  for (std::size_t a = 0; a < spec.algorithms.size(); ++a) {
    for (std::size_t v = 0; v < spec.variants.size(); ++v) {
      for (std::size_t value = 0; value < spec.swept_values.size(); ++value) {
        try {
          (void)config::load_scenario(spec.algorithms[a].scenario.string(),
                                      cell_overrides(spec, a, v, value, spec.seeds.front()));
        } catch (const config::ScenarioError& error) {
          throw config::ScenarioError("campaign spec " + path.string() + ", cell " +
                                      cell_name(spec, a, v, value) + ": " + error.what());
        }
      }
    }
  }
}

}  // namespace

std::vector<std::string> parse_mode_flag(const std::string& mode) {
  return parse_modes(mode, SpecReader("--mode"), "--mode");
}

/// Overrides of one cell, in the order they apply (later wins).
std::vector<std::string> cell_overrides(const CampaignSpec& spec, std::size_t algorithm, std::size_t variant,
                                        std::size_t value, std::uint64_t seed) {
  std::vector<std::string> out = spec.overrides;
  const auto& a = spec.algorithms[algorithm].overrides;
  const auto& v = spec.variants[variant].overrides;
  out.insert(out.end(), a.begin(), a.end());
  out.insert(out.end(), v.begin(), v.end());
  out.push_back(spec.swept_key + "=" + spec.swept_values[value]);
  out.push_back("seed=" + std::to_string(seed));
  return out;
}

std::string cell_name(const CampaignSpec& spec, std::size_t algorithm, std::size_t variant,
                      std::size_t value) {
  return spec.algorithms[algorithm].label + " / " + spec.variants[variant].label + " / " + spec.swept_key +
         "=" + spec.swept_values[value];
}

/// A label as a directory name.
std::string path_safe(const std::string& text) {
  std::string out;
  for (char c : text) out += (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-') ? c : '_';
  return out;
}

CampaignSpec load_spec(const std::filesystem::path& path) {
  const SpecReader reader(path.string());
  YAML::Node root;
  try {
    root = YAML::LoadFile(path.string());
  } catch (const YAML::BadFile&) {
    throw config::ScenarioError("campaign spec " + path.string() + ": cannot read the file");
  } catch (const YAML::Exception& error) {
    throw config::ScenarioError("campaign spec " + path.string() + ": YAML error: " + error.what());
  }
  reader.require_keys(root, "",
                      {"name", "mode", "seeds", "dds_seeds", "threads", "overrides", "algorithms", "sweep",
                       "variants", "check"});
  CampaignSpec spec;
  read_top_level(root, reader, spec);
  read_algorithms(root, reader, path.parent_path(), spec);
  read_sweep(root, reader, spec);
  read_variants(root, reader, spec);
  read_check(root, reader, spec);
  check_every_cell_loads(spec, path);
  return spec;
}

}  // namespace campaign_detail

CampaignSpec load_campaign_spec(const std::filesystem::path& path) {
  return campaign_detail::load_spec(path);
}

std::string campaign_spec_yaml(const CampaignSpec& spec) {
  YAML::Emitter out;
  auto overrides_map = [&](const std::vector<std::string>& overrides) {
    out << YAML::BeginMap;
    for (const auto& o : overrides) {
      const auto eq = o.find('=');
      out << YAML::Key << o.substr(0, eq) << YAML::Value << o.substr(eq + 1);
    }
    out << YAML::EndMap;
  };
  out << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << spec.name;
  out << YAML::Key << "mode" << YAML::Value << (spec.modes.size() == 2 ? "both" : spec.modes.front());
  out << YAML::Key << "seeds" << YAML::Value << YAML::Flow << spec.seeds;
  if (!spec.dds_seeds.empty()) out << YAML::Key << "dds_seeds" << YAML::Value << YAML::Flow << spec.dds_seeds;
  out << YAML::Key << "threads" << YAML::Value << spec.threads;
  out << YAML::Key << "overrides" << YAML::Value;
  overrides_map(spec.overrides);
  out << YAML::Key << "algorithms" << YAML::Value << YAML::BeginSeq;
  for (const auto& a : spec.algorithms) {
    out << YAML::BeginMap << YAML::Key << "label" << YAML::Value << a.label << YAML::Key << "scenario"
        << YAML::Value << std::filesystem::absolute(a.scenario).lexically_normal().string() << YAML::Key
        << "overrides" << YAML::Value;
    overrides_map(a.overrides);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::Key << "sweep" << YAML::Value << YAML::BeginMap << YAML::Key << "key" << YAML::Value
      << spec.swept_key << YAML::Key << "values" << YAML::Value << YAML::Flow << spec.swept_values
      << YAML::EndMap;
  out << YAML::Key << "variants" << YAML::Value << YAML::BeginSeq;
  for (const auto& v : spec.variants) {
    out << YAML::BeginMap << YAML::Key << "label" << YAML::Value << v.label << YAML::Key << "overrides"
        << YAML::Value;
    overrides_map(v.overrides);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  if (spec.check_value) {
    out << YAML::Key << "check" << YAML::Value << YAML::BeginMap << YAML::Key << "value" << YAML::Value
        << *spec.check_value << YAML::Key << "max_ratio" << YAML::Value << spec.check_max_ratio
        << YAML::EndMap;
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

}  // namespace swarmloc::research
