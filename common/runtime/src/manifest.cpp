#include "swarmloc/runtime/manifest.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "swarmloc/runtime/output_file.hpp"

namespace swarmloc::runtime {
namespace {

using nlohmann::json;

constexpr const char* kFormat = "swarmloc-agent-manifest";
constexpr int kMaxAgents = 10'000'000;
constexpr std::uintmax_t kMaxFileBytes = 64u << 20;

std::string hex64(std::uint64_t value) {
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(value));
  return text;
}

/// +inf (nothing known) is written as null: JSON has no infinity.
json finite_or_null(double value) { return std::isfinite(value) ? json(value) : json(nullptr); }

json runtime_json(const AgentManifest& m) {
  const AgentRuntimeParams& p = m.runtime;
  json runtime = {{"seed", hex64(p.seed)},
                  {"loss_probability", p.loss.loss_probability},
                  {"burst_mean_length", p.loss.burst_mean_length},
                  {"absurd_position_bound_m", p.absurd_position_bound_m},
                  {"absurd_variance_m2", p.absurd_variance_m2},
                  {"world_period_s", p.world_period_s}};
  if (p.partition_group.empty()) return runtime;
  json groups = json::object();
  auto add = [&](AgentId agent) {
    const auto at = static_cast<std::size_t>(agent);
    if (at < p.partition_group.size()) groups[std::to_string(agent)] = p.partition_group[at];
  };
  add(m.id);
  for (const AgentId neighbour : m.neighbours) add(neighbour);
  runtime["partition"] = {{"from_step", p.partition_from}, {"to_step", p.partition_to}, {"groups", groups}};
  return runtime;
}

/// Reading with the field's name in every error.
class Reader {
 public:
  Reader(const json& object, std::string where, const std::string& source)
      : object_(object), where_(std::move(where)), source_(source) {
    if (!object_.is_object()) fail("", "must be an object");
  }
  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    const std::string field = key.empty() ? where_ : (where_.empty() ? key : where_ + "." + key);
    throw ManifestError(source_ + ": invalid agent manifest: " + (field.empty() ? "" : field + " ") + what);
  }
  const json& at(const std::string& key) const {
    const auto it = object_.find(key);
    if (it == object_.end()) fail(key, "is missing");
    return *it;
  }
  [[nodiscard]] bool has(const std::string& key) const { return object_.contains(key); }
  double number(const std::string& key, bool null_is_inf = false) const {
    const json& value = at(key);
    if (null_is_inf && value.is_null()) return std::numeric_limits<double>::infinity();
    if (!value.is_number()) fail(key, "must be a number");
    const double x = value.get<double>();
    if (!std::isfinite(x)) fail(key, "must be finite");
    return x;
  }
  std::int64_t integer(const std::string& key, std::int64_t low, std::int64_t high) const {
    const json& value = at(key);
    if (!value.is_number_integer()) fail(key, "must be an integer");
    if (value.is_number_unsigned() && value.get<std::uint64_t>() > static_cast<std::uint64_t>(high))
      fail(key, "is out of range");
    const auto x = value.get<std::int64_t>();
    if (x < low || x > high)
      fail(key, "must lie in [" + std::to_string(low) + ", " + std::to_string(high) + "]");
    return x;
  }
  bool boolean(const std::string& key) const {
    const json& value = at(key);
    if (!value.is_boolean()) fail(key, "must be true or false");
    return value.get<bool>();
  }
  std::string text(const std::string& key) const {
    const json& value = at(key);
    if (!value.is_string()) fail(key, "must be a string");
    return value.get<std::string>();
  }
  std::uint64_t hex(const std::string& key) const {
    const std::string value = text(key);
    if (value.size() != 16 || value.find_first_not_of("0123456789abcdef") != std::string::npos)
      fail(key, "must be 16 lower-case hex digits");
    return std::stoull(value, nullptr, 16);
  }
  Reader child(const std::string& key) const {
    return Reader(at(key), where_.empty() ? key : where_ + "." + key, source_);
  }

 private:
  const json& object_;
  std::string where_;
  const std::string& source_;
};

estimators::AgentSetup read_setup(const Reader& r, AgentId id) {
  estimators::AgentSetup setup;
  setup.id = id;
  setup.anchor = r.boolean("anchor");
  const json& guess = r.at("initial_guess_m");
  if (!guess.is_array() || guess.size() != 2 || !guess[0].is_number() || !guess[1].is_number())
    r.fail("initial_guess_m", "must be [x, y]");
  setup.initial_guess_m = Vec2(guess[0].get<double>(), guess[1].get<double>());
  if (!setup.initial_guess_m.allFinite()) r.fail("initial_guess_m", "must be finite");
  setup.initial_heading_rad = r.number("initial_heading_rad");
  setup.initial_guess_std_m = r.number("initial_guess_std_m", true);
  if (setup.initial_guess_std_m < 0.0) r.fail("initial_guess_std_m", "must be >= 0 (null: unknown)");
  if (r.has("comm_radius_m")) {  // manifests written before it: unknown
    setup.comm_radius_m = r.number("comm_radius_m", true);
    if (!(setup.comm_radius_m > 0.0)) r.fail("comm_radius_m", "must be > 0 (null: unknown)");
  }
  if (r.has("dimensions")) setup.dimensions = static_cast<int>(r.integer("dimensions", 2, 3));  // else planar
  if (r.has("initial_altitude_m")) setup.initial_altitude_m = r.number("initial_altitude_m");
  return setup;
}

std::vector<AgentId> read_neighbours(const Reader& r, const json& list, AgentId id, int agents) {
  if (!list.is_array()) r.fail("neighbours", "must be an array of agent ids");
  if (list.size() >= static_cast<std::size_t>(agents)) r.fail("neighbours", "has more entries than agents");
  std::vector<AgentId> neighbours;
  neighbours.reserve(list.size());
  for (const json& entry : list) {
    if (!entry.is_number_integer()) r.fail("neighbours", "must hold integers");
    const auto neighbour = entry.get<std::int64_t>();
    if (neighbour < 0 || neighbour >= agents || neighbour == id)
      r.fail("neighbours", "holds " + std::to_string(neighbour) + ": not another agent of the network");
    if (!neighbours.empty() && neighbour <= neighbours.back())
      r.fail("neighbours", "must be sorted and without repeats");
    neighbours.push_back(static_cast<AgentId>(neighbour));
  }
  return neighbours;
}

void read_partition(const Reader& r, AgentManifest& m) {
  AgentRuntimeParams& p = m.runtime;
  constexpr std::int64_t kMaxStep = std::numeric_limits<std::int64_t>::max() / 4;
  p.partition_from = r.integer("from_step", -1, kMaxStep);
  p.partition_to = r.integer("to_step", -1, kMaxStep);
  const Reader groups = r.child("groups");
  p.partition_group.assign(static_cast<std::size_t>(m.agent_count), 0);
  auto read = [&](AgentId agent) {
    p.partition_group[static_cast<std::size_t>(agent)] =
        static_cast<std::uint8_t>(groups.integer(std::to_string(agent), 0, 1));
  };
  read(m.id);
  for (const AgentId neighbour : m.neighbours) read(neighbour);
}

void read_runtime(const Reader& r, AgentManifest& m) {
  AgentRuntimeParams& p = m.runtime;
  p.seed = r.hex("seed");
  p.loss.loss_probability = r.number("loss_probability");
  if (p.loss.loss_probability < 0.0 || p.loss.loss_probability > 1.0)
    r.fail("loss_probability", "must lie in [0, 1]");
  p.loss.burst_mean_length = r.number("burst_mean_length");
  if (p.loss.burst_mean_length < 0.0) r.fail("burst_mean_length", "must be >= 0");
  p.absurd_position_bound_m = r.number("absurd_position_bound_m");
  p.absurd_variance_m2 = r.number("absurd_variance_m2");
  if (!(p.absurd_position_bound_m > 0.0) || !(p.absurd_variance_m2 > 0.0))
    r.fail("absurd_position_bound_m", "and absurd_variance_m2 must be positive");
  p.world_period_s = r.number("world_period_s");
  if (!(p.world_period_s > 0.0)) r.fail("world_period_s", "must be positive");
  if (r.has("partition")) read_partition(r.child("partition"), m);
}

AgentManifest read_manifest(const Reader& r) {
  if (r.text("format") != kFormat) r.fail("format", std::string("must be \"") + kFormat + "\"");
  if (r.integer("version", 0, std::numeric_limits<int>::max()) != kManifestVersion)
    r.fail("version", "must be " + std::to_string(kManifestVersion) + " (written by another build?)");
  AgentManifest m;
  m.agent_count = static_cast<int>(r.integer("agents", 1, kMaxAgents));
  m.id = static_cast<AgentId>(r.integer("id", 0, m.agent_count - 1));
  m.run_id = r.text("run_id");
  if (m.run_id.empty()) r.fail("run_id", "must not be empty");
  m.results_hash = r.hex("results_hash");
  m.setup = read_setup(r.child("setup"), m.id);
  m.neighbours = read_neighbours(r, r.at("neighbours"), m.id, m.agent_count);
  const Reader clock = r.child("clock");
  m.clock.offset_s = clock.number("offset_s");
  m.clock.drift_ppm = clock.number("drift_ppm");
  if (std::abs(m.clock.drift_ppm) >= 1e6) clock.fail("drift_ppm", "must lie in (-1e6, 1e6)");
  read_runtime(r.child("runtime"), m);
  return m;
}

}  // namespace

std::filesystem::path manifest_path(const std::filesystem::path& run_dir, AgentId id) {
  char name[32];
  std::snprintf(name, sizeof name, "agent_%03d.json", id);
  return run_dir / "manifests" / name;
}

std::string to_json_text(const AgentManifest& m) {
  json setup = {{"anchor", m.setup.anchor},
                {"initial_guess_m", {m.setup.initial_guess_m.x(), m.setup.initial_guess_m.y()}},
                {"initial_heading_rad", m.setup.initial_heading_rad},
                {"initial_guess_std_m", finite_or_null(m.setup.initial_guess_std_m)},
                {"comm_radius_m", finite_or_null(m.setup.comm_radius_m)}};
  if (m.setup.dimensions != 2) {  // planar manifests stay as they were
    setup["dimensions"] = m.setup.dimensions;
    setup["initial_altitude_m"] = m.setup.initial_altitude_m;
  }
  const json manifest = {{"format", kFormat},
                         {"version", kManifestVersion},
                         {"id", m.id},
                         {"agents", m.agent_count},
                         {"run_id", m.run_id},
                         {"results_hash", hex64(m.results_hash)},
                         {"setup", setup},
                         {"neighbours", m.neighbours},
                         {"clock", {{"offset_s", m.clock.offset_s}, {"drift_ppm", m.clock.drift_ppm}}},
                         {"runtime", runtime_json(m)}};
  return manifest.dump(1) + "\n";
}

AgentManifest parse_manifest(const std::string& text, const std::string& source) {
  json document;
  try {
    document = json::parse(text);
  } catch (const json::exception& error) {
    throw ManifestError(source + ": not a JSON agent manifest: " + error.what());
  }
  try {
    return read_manifest(Reader(document, "", source));
  } catch (const json::exception& error) {  // e.g. an integer beyond int64
    throw ManifestError(source + ": invalid agent manifest: " + error.what());
  }
}

void write_manifest(const std::filesystem::path& path, const AgentManifest& manifest) {
  std::error_code error;
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), error);
  if (error) throw OutputError(path.parent_path(), "create the directory", error.value());
  write_text_file(path, to_json_text(manifest));
}

AgentManifest load_manifest(const std::filesystem::path& path) {
  std::error_code error;
  const auto size = std::filesystem::file_size(path, error);
  if (error) throw ManifestError(path.string() + ": cannot read the agent manifest: " + error.message());
  if (size > kMaxFileBytes) throw ManifestError(path.string() + ": too large for an agent manifest");
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  if (!in && !in.eof()) throw ManifestError(path.string() + ": cannot read the agent manifest");
  return parse_manifest(text.str(), path.string());
}

}  // namespace swarmloc::runtime
