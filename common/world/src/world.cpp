#include "swarmloc/world/world.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <numeric>
#include <queue>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "swarmloc/core/random.hpp"
#include "swarmloc/estimators/crlb.hpp"
#include "swarmloc/models/measurement_models.hpp"
#include "swarmloc/world/mrclam.hpp"

namespace swarmloc::world {
namespace {

using config::Scenario;

std::vector<Vec2> read_positions_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw config::ScenarioError("world.positions_file: '" + path + "' cannot be read");
  std::vector<Vec2> positions;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.empty() || line[0] == '#') continue;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream fields(line);
    double x = 0.0;
    double y = 0.0;
    if (!(fields >> x >> y) || !std::isfinite(x) || !std::isfinite(y)) {
      throw config::ScenarioError("world.positions_file: '" + path + "' line " + std::to_string(line_number) +
                                  ": expected 'x,y'");
    }
    positions.emplace_back(x, y);
  }
  return positions;
}

std::vector<Vec2> place(const Scenario& s, int attempt) {
  const int n = s.world.agents;
  std::vector<Vec2> positions;
  positions.reserve(static_cast<std::size_t>(n));
  switch (s.world.placement) {
    case config::Placement::kUniform: {
      auto rng = core::make_engine(s.seed, core::Stream::kPlacement, attempt);
      std::uniform_real_distribution<double> u(0.0, s.world.area_m);
      for (int i = 0; i < n; ++i) positions.emplace_back(u(rng), u(rng));
      break;
    }
    case config::Placement::kGrid: {
      const int side = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(n))));
      const double spacing = s.world.area_m / std::max(1, side - 1);
      for (int i = 0; i < n; ++i) {
        const int column = i % side;
        const int row = i / side;  // integer division on purpose: the grid row index
        positions.emplace_back(column * spacing, row * spacing);
      }
      break;
    }
    case config::Placement::kFile: {
      positions = read_positions_file(s.world.positions_file);
      if (static_cast<int>(positions.size()) != n) {
        throw config::ScenarioError("world.positions_file: has " + std::to_string(positions.size()) +
                                    " positions but world.agents is " + std::to_string(n));
      }
      break;
    }
  }
  return positions;
}

/// The z of every agent, one per agent in a 3-D world, empty in a planar one.
std::vector<double> place_altitudes(const Scenario& s, int attempt) {
  if (s.world.dimensions != 3) return {};
  // Its own stream, so a planar world's draws are what they were.
  auto rng = core::make_engine(s.seed, core::Stream::kPlacement, attempt, -3);
  std::uniform_real_distribution<double> u(0.0, s.world.height_m);
  std::vector<double> z(static_cast<std::size_t>(s.world.agents));
  for (auto& value : z) value = u(rng);
  return z;
}

/// Anchors at evenly spread heights, (k + ½)/A of the box in id order: a uniform draw can leave all of them
/// near one plane, which fixes nothing across it.
void spread_anchor_heights(std::vector<double>& z, const std::vector<bool>& is_anchor, double height_m) {
  if (z.empty()) return;
  const auto anchors = static_cast<double>(std::count(is_anchor.begin(), is_anchor.end(), true));
  double k = 0.0;
  for (std::size_t i = 0; i < z.size(); ++i) {
    if (is_anchor[i]) z[i] = height_m * (k++ + 0.5) / anchors;
  }
}

std::vector<std::vector<AgentId>> disk_graph(const std::vector<Vec2>& positions, const std::vector<double>& z,
                                             double radius, const WorkControl& control,
                                             const std::string& draw) {
  const int n = static_cast<int>(positions.size());
  std::vector<std::vector<AgentId>> neighbours(static_cast<std::size_t>(n));
  // Grid bucketing keeps this O(N · degree) for the 10^4–10^5 agent simulations.
  const double cell = radius;
  Vec2 lo = positions.empty() ? Vec2::Zero() : positions[0];
  for (const auto& p : positions) lo = lo.cwiseMin(p);
  std::unordered_map<std::int64_t, std::vector<int>> buckets;
  auto key = [&](const Vec2& p, int dx, int dy) {
    const auto cx = static_cast<std::int64_t>(std::floor((p.x() - lo.x()) / cell)) + dx;
    const auto cy = static_cast<std::int64_t>(std::floor((p.y() - lo.y()) / cell)) + dy;
    return cx * 1000003LL + cy;
  };
  for (int i = 0; i < n; ++i) buckets[key(positions[static_cast<std::size_t>(i)], 0, 0)].push_back(i);
  // A dense world (10^5 agents in the default 40 m square: ~31 000 neighbours each) takes minutes and
  // gigabytes here: the running degree tells the user why.
  WorkPhase phase(control, "world" + draw + ": neighbour graph");
  std::size_t links = 0;
  for (int i = 0; i < n; ++i) {
    if (i > 0 && i % 64 == 0) {
      phase.rename("world" + draw + ": neighbour graph, " +
                   std::to_string(links / static_cast<std::size_t>(i)) + " neighbours per agent so far");
    }
    phase.tick(static_cast<std::size_t>(i), static_cast<std::size_t>(n));
    const Vec2& p = positions[static_cast<std::size_t>(i)];
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        const auto it = buckets.find(key(p, dx, dy));
        if (it == buckets.end()) continue;
        for (int j : it->second) {
          const auto k = static_cast<std::size_t>(j);
          // In space the planar buckets still hold every neighbour: a distance is at least its planar part.
          const double distance =
              z.empty() ? (positions[k] - p).norm()
                        : (join(positions[k], z[k]) - join(p, z[static_cast<std::size_t>(i)])).norm();
          if (j != i && distance <= radius) {
            neighbours[static_cast<std::size_t>(i)].push_back(j);
          }
        }
      }
    }
    std::sort(neighbours[static_cast<std::size_t>(i)].begin(), neighbours[static_cast<std::size_t>(i)].end());
    links += neighbours[static_cast<std::size_t>(i)].size();
  }
  return neighbours;
}

/// Every non-anchor agent has >= 2 neighbours and reaches an anchor (a cheap proxy for localizability).
bool acceptable(const std::vector<std::vector<AgentId>>& neighbours, const std::vector<bool>& is_anchor,
                const WorkControl& control, const std::string& draw) {
  const auto n = neighbours.size();
  WorkPhase phase(control, "world" + draw + ": connectivity check");
  std::size_t visited = 0;
  std::vector<bool> reached(n, false);
  std::queue<std::size_t> frontier;
  bool any_anchor = false;
  for (std::size_t i = 0; i < n; ++i) {
    if (is_anchor[i]) {
      reached[i] = true;
      frontier.push(i);
      any_anchor = true;
    }
  }
  if (!any_anchor) frontier.push(0), reached[0] = true;  // anchor-free: require plain connectivity
  while (!frontier.empty()) {
    const auto i = frontier.front();
    frontier.pop();
    phase.tick(visited++, n);
    for (AgentId j : neighbours[i]) {
      if (!reached[static_cast<std::size_t>(j)])
        reached[static_cast<std::size_t>(j)] = true, frontier.push(static_cast<std::size_t>(j));
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!reached[i]) return false;
    if (!is_anchor[i] && n > 2 && neighbours[i].size() < 2) return false;
  }
  return true;
}

std::vector<bool> choose_anchors(const Scenario& s, int attempt) {
  std::vector<bool> is_anchor(static_cast<std::size_t>(s.world.agents), false);
  std::vector<int> order(static_cast<std::size_t>(s.world.agents));
  std::iota(order.begin(), order.end(), 0);
  auto rng = core::make_engine(s.seed, core::Stream::kAnchors, attempt);
  std::shuffle(order.begin(), order.end(), rng);
  for (int k = 0; k < s.world.anchors; ++k)
    is_anchor[static_cast<std::size_t>(order[static_cast<std::size_t>(k)])] = true;
  return is_anchor;
}

constexpr int kMaxLocalizabilityCheckUnknowns = 1000;  // dense 2n × 2n LDLT per draw: ~0.3 s at 1000

/// Every non-anchor agent localizable from its ranges: the Fisher information at the truth (unit range std;
/// the scale does not matter) has no (near-)zero pivot. Skipped (true) above the size limit.
bool range_localizable(const World& world) {
  const auto& is_anchor = world.is_anchor;
  const auto unknowns = std::count(is_anchor.begin(), is_anchor.end(), false);
  if (unknowns == 0 || unknowns > kMaxLocalizabilityCheckUnknowns) return true;
  std::vector<estimators::RangeObservation> ranges;
  for (std::size_t i = 0; i < world.neighbours.size(); ++i) {
    for (const AgentId j : world.neighbours[i]) {
      if (static_cast<std::size_t>(j) > i) ranges.push_back({static_cast<AgentId>(i), j, 1.0});
    }
  }
  MatX fisher;
  if (world.dimensions == 3) {
    estimators::RangeNetwork3 network;
    for (AgentId i = 0; i < world.size(); ++i) network.truth.push_back(world.position3(i));
    network.is_anchor = is_anchor;
    network.ranges = std::move(ranges);
    fisher = estimators::range_network_fisher(network);
  } else {
    estimators::RangeNetwork network;
    network.truth = world.truth;
    network.is_anchor = is_anchor;
    network.ranges = std::move(ranges);
    fisher = estimators::range_network_fisher(network);
  }
  const Eigen::LDLT<MatX> ldlt(fisher);
  if (ldlt.info() != Eigen::Success) return false;
  const auto pivots = ldlt.vectorD().cwiseAbs();
  return pivots.minCoeff() > 1e-9 * std::max(1.0, pivots.maxCoeff());
}

}  // namespace

int World::anchor_count() const {
  return static_cast<int>(std::count(is_anchor.begin(), is_anchor.end(), true));
}

double World::mean_degree() const {
  if (neighbours.empty()) return 0.0;
  std::size_t edges = 0;
  for (const auto& n : neighbours) edges += n.size();
  return static_cast<double>(edges) / static_cast<double>(neighbours.size());
}

Vec2 World::scored_truth(AgentId id) const {
  return estimates_target() ? Vec2(target.head<2>()) : truth.at(static_cast<std::size_t>(id));
}

double World::scored_truth_z(AgentId id) const {
  return dimensions == 3 && !estimates_target() ? altitude.at(static_cast<std::size_t>(id)) : 0.0;
}

bool World::scored(AgentId id) const {
  return estimates_target() || !is_anchor.at(static_cast<std::size_t>(id));
}

estimators::AgentSetup World::setup_of(AgentId id) const {
  const auto i = static_cast<std::size_t>(id);
  estimators::AgentSetup setup{id, is_anchor.at(i), is_anchor.at(i) ? truth.at(i) : initial_guess.at(i)};
  if (i < initial_heading.size()) setup.initial_heading_rad = initial_heading[i];
  setup.initial_guess_std_m = initial_guess_std_m;
  setup.comm_radius_m = comm_radius_m;
  setup.dimensions = dimensions;
  if (dimensions == 3) setup.initial_altitude_m = is_anchor.at(i) ? altitude.at(i) : initial_altitude.at(i);
  return setup;
}

Vec3 World::position3(AgentId id) const {
  const auto i = static_cast<std::size_t>(id);
  return join(truth.at(i), dimensions == 3 ? altitude.at(i) : 0.0);
}

double World::distance(AgentId a, AgentId b) const {
  if (dimensions == 3) return (position3(a) - position3(b)).norm();
  return (truth.at(static_cast<std::size_t>(a)) - truth.at(static_cast<std::size_t>(b))).norm();
}

std::uint64_t trial_seed(std::uint64_t seed, std::uint64_t trial) {
  return trial == 0 ? seed : core::hash_keys(seed, 0x7472696171ULL, trial);
}

namespace {

constexpr int kMaxAttempts = 1000;  // placement draws

/// Draws placements (positions, anchors, links) until one is connected and localizable, or replays
/// `accepted_draw` (≥ 0) as recorded; throws ScenarioError when no draw is acceptable.
void draw_placement(World& world, const Scenario& s, int accepted_draw, const WorkControl& control) {
  const bool random_placement = s.world.placement == config::Placement::kUniform;
  // Up to kMaxAttempts draws (each a localizability check of up to 0.3 s): progress counts them.
  WorkPhase draws(control, "world: placement draws");
  for (int attempt = std::max(accepted_draw, 0); attempt < kMaxAttempts; ++attempt) {
    draws.rename("world: placement draw " + std::to_string(attempt + 1) + " of at most " +
                 std::to_string(kMaxAttempts) + " (redrawn until every agent is connected and localizable)");
    draws.tick(static_cast<std::size_t>(attempt), kMaxAttempts);
    const std::string draw = attempt == 0 ? "" : " (draw " + std::to_string(attempt + 1) + ")";
    world.truth = place(s, attempt);
    world.is_anchor = choose_anchors(s, attempt);
    world.altitude = place_altitudes(s, attempt);
    spread_anchor_heights(world.altitude, world.is_anchor, s.world.height_m);
    world.neighbours = disk_graph(world.truth, world.altitude, s.world.comm_radius_m, control, draw);
    world.placement_attempts = attempt + 1;
    const bool connected =
        !s.world.require_connected || acceptable(world.neighbours, world.is_anchor, control, draw);
    if (accepted_draw >= 0) {
      if (!connected)
        throw config::ScenarioError("accepted world draw " + std::to_string(accepted_draw) +
                                    " is not connected: it does not belong to this scenario");
      break;
    }
    const bool localizable = !connected || !s.world.require_localizable ||
                             !measurement_kinds(s.algorithm.name).ranges || range_localizable(world);
    if (connected && localizable) break;
    if (attempt + 1 == kMaxAttempts || (!random_placement && attempt >= s.world.anchors)) {
      throw config::ScenarioError(
          connected
              ? "world.comm_radius_m: no placement within " + std::to_string(attempt + 1) +
                    " draws makes every agent localizable from its ranges; raise the radius or set "
                    "world.require_localizable: false"
              : "world.comm_radius_m: no placement within " + std::to_string(attempt + 1) +
                    " draws connects every agent to an anchor with >= 2 neighbours; raise the radius or "
                    "set world.require_connected: false");
    }
  }
}

/// The z of every initial guess, from its own stream (a planar world's guesses stay what they were): the
/// truth's plus the same per-axis noise, or uniform over the box's height; anchors know theirs.
void draw_initial_altitudes(World& world, const Scenario& s, std::uint64_t trial) {
  auto rng = core::make_engine(trial_seed(s.seed, trial), core::Stream::kInitialGuess, -3);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, s.world.height_m);
  world.initial_altitude.resize(world.altitude.size());
  for (std::size_t i = 0; i < world.altitude.size(); ++i) {
    world.initial_altitude[i] = s.world.initial_guess == config::InitialGuess::kUniform
                                    ? uniform(rng)
                                    : world.altitude[i] + s.world.initial_guess_std_m * gauss(rng);
    if (world.is_anchor[i]) world.initial_altitude[i] = world.altitude[i];
  }
}

/// Every agent's initial guess (the trial's draws) and the std an agent may assume for it.
void draw_initial_guesses(World& world, const Scenario& s, std::uint64_t trial,
                          const MeasurementKinds& kinds) {
  const auto n = static_cast<std::size_t>(s.world.agents);
  world.initial_guess.resize(n);
  // How far off a start may be, which an agent may know (a deployment plan's tolerance): the guess's std,
  // or that of a uniform draw over the area.
  world.initial_guess_std_m = s.world.initial_guess == config::InitialGuess::kUniform
                                  ? s.world.area_m / std::sqrt(12.0)
                                  : s.world.initial_guess_std_m;
  auto rng = core::make_engine(trial_seed(s.seed, trial), core::Stream::kInitialGuess);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, s.world.area_m);
  for (std::size_t i = 0; i < n; ++i) {
    if (s.world.initial_guess == config::InitialGuess::kUniform) {
      world.initial_guess[i] = Vec2(uniform(rng), uniform(rng));
    } else {
      world.initial_guess[i] = world.truth[i] + s.world.initial_guess_std_m * Vec2(gauss(rng), gauss(rng));
    }
    // Anchors know their position; so does every sensor of a target-estimating world (Atanasov et al. Sec.
    // II).
    if (world.is_anchor[i] || kinds.targets) world.initial_guess[i] = world.truth[i];
  }
  if (world.dimensions == 3) draw_initial_altitudes(world, s, trial);
}

/// What the algorithm measures besides its peers (a field, a target, walls), and every agent's clock.
void add_environment(World& world, const Scenario& s, const MeasurementKinds& kinds) {
  const auto n = static_cast<std::size_t>(s.world.agents);
  if (kinds.field) {
    auto field_rng = core::make_engine(s.seed, core::Stream::kPlacement, -2);  // the world's, not the trial's
    world.field = draw_gaussian_field(config::field_sensor(s).grid, s.world.field_std,
                                      s.world.field_correlation_m, field_rng);
  }
  if (kinds.targets) {
    world.target = VecX::Zero(config::target_model(s).dim);
    world.target.head<2>() = Vec2(s.world.target_x_m, s.world.target_y_m);
    if (world.target.size() == 4) world.target.tail<2>() = Vec2(s.world.target_vx_mps, s.world.target_vy_mps);
  }
  if (kinds.paths) world.walls = make_walls(s);
  world.clocks.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    world.clocks.push_back(
        core::draw_clock(s.seed, static_cast<AgentId>(i), s.clock.offset_max_s, s.clock.drift_ppm));
  }
}

}  // namespace

World build_world(const Scenario& s, std::uint64_t trial, int accepted_draw, const WorkControl& control) {
  control.throw_if_cancelled();
  if (s.world.source == config::WorldSource::kMrclam) return build_mrclam_world(s);
  World world;
  world.trial = trial;
  world.dimensions = s.world.dimensions;
  if (accepted_draw >= kMaxAttempts)
    throw config::ScenarioError("accepted world draw " + std::to_string(accepted_draw) +
                                " is >= " + std::to_string(kMaxAttempts));
  draw_placement(world, s, accepted_draw, control);
  world.comm_radius_m = s.world.comm_radius_m;
  const MeasurementKinds kinds = measurement_kinds(s.algorithm.name);
  draw_initial_guesses(world, s, trial, kinds);
  add_environment(world, s, kinds);
  control.throw_if_cancelled();
  return world;
}

void attach_recorded(World& world, std::shared_ptr<const RecordedSteps> recorded) {
  if (!recorded) return;
  if (recorded->steps() < 1) throw std::invalid_argument("attach_recorded: the recording holds no step");
  auto truth = recorded->truth(0);
  if (truth.size() != world.truth.size()) {
    throw std::invalid_argument("attach_recorded: the recording has " + std::to_string(truth.size()) +
                                " agents, the world " + std::to_string(world.truth.size()));
  }
  world.truth = std::move(truth);
  world.recorded = std::move(recorded);
}

VecX draw_gaussian_field(const estimators::consensus::FieldGrid& grid, double std_dev, double correlation_m,
                         std::mt19937_64& rng) {
  const int d = grid.cells();
  MatX C(d, d);
  for (int k = 0; k < d; ++k) {
    for (int l = 0; l < d; ++l) {
      const double r2 = (grid.centre(k) - grid.centre(l)).squaredNorm();
      C(k, l) = std::exp(-r2 / (2.0 * correlation_m * correlation_m));
    }
  }
  C.diagonal().array() += 1e-9;  // the squared-exponential kernel is numerically semi-definite
  const Eigen::LLT<MatX> llt(C);
  std::normal_distribution<double> normal(0.0, 1.0);
  VecX xi(d);
  for (int k = 0; k < d; ++k) xi(k) = normal(rng);
  const VecX correlated = llt.matrixL() * xi;
  return std_dev * correlated;
}

namespace {

/// y(k) = F y(k−1) + η, η ~ N(0, W) (Atanasov et al. eq. (1)); one seeded draw per step.
void advance_target(World& world, const Scenario& s, std::int64_t step) {
  if (!world.estimates_target() || s.world.target_motion == config::TargetMotion::kStatic) return;
  const config::TargetModel model = config::target_model(s);
  const Eigen::LLT<MatX> root(model.W);
  auto rng = core::make_engine(trial_seed(s.seed, world.trial), core::Stream::kMotion, step, -1);
  std::normal_distribution<double> gauss(0.0, 1.0);
  VecX eta(model.dim);
  for (auto& e : eta) e = gauss(rng);
  // W is singular when q = 0 (a constant-velocity target): no noise then.
  world.target = model.F * world.target;
  if (root.info() == Eigen::Success) world.target += root.matrixL() * eta;
}

}  // namespace

void advance_truth(World& world, const Scenario& s, std::int64_t step) {
  advance_target(world, s, step);
  if (world.recorded) {
    world.truth = world.recorded->truth(step);
    return;
  }
  if (s.world.motion != config::Motion::kRandomWalk || s.world.motion_std_m <= 0.0) return;
  std::normal_distribution<double> gauss(0.0, s.world.motion_std_m);
  for (std::size_t i = 0; i < world.truth.size(); ++i) {
    if (world.is_anchor[i]) continue;
    auto rng = core::make_engine(trial_seed(s.seed, world.trial), core::Stream::kMotion, step,
                                 static_cast<std::int64_t>(i));
    world.truth[i] += Vec2(gauss(rng), gauss(rng));
    // In space the same stream's third draw moves z, so a planar world's walk is unchanged.
    if (world.dimensions == 3) world.altitude[i] += gauss(rng);
  }
}

MeasurementKinds measurement_kinds(const std::string& algorithm) {
  // An unknown name (never a validated scenario's) gets the range family's data.
  const config::AlgorithmSpec* spec = config::find_algorithm(algorithm);
  return spec != nullptr ? spec->kinds : MeasurementKinds{.ranges = true, .anchor_fixes = true};
}

std::vector<models::Wall> make_walls(const Scenario& s) {
  std::vector<models::Wall> walls;
  const Vec2 center(0.5 * s.world.area_m, 0.5 * s.world.area_m);
  const double offset = s.world.area_m * std::numbers::sqrt2 / 2.0 + s.world.wall_margin_m;
  for (int k = 0; k < s.world.wall_count; ++k) {
    const double angle =
        (s.world.wall_first_angle_deg + k * s.world.wall_angle_step_deg) * std::numbers::pi / 180.0;
    const Vec2 normal(-std::sin(angle), std::cos(angle));
    walls.push_back(models::Wall{center - offset * normal, angle});
  }
  return walls;
}

namespace {

/// Key of one noise draw: the step (0 when drawn once per run) and the ids that own it.
template <typename... Keys>
std::uint64_t noise_key(const World& world, const Scenario& s, std::int64_t step, Keys... keys) {
  const std::int64_t draw_step = s.noise.draw == config::NoiseDraw::kOnce ? 0 : step;
  return core::hash_keys(trial_seed(s.seed, world.trial),
                         static_cast<std::uint64_t>(core::Stream::kMeasurementNoise), draw_step, keys...);
}

void add_paths(const World& world, const Scenario& s, AgentId agent, AgentId peer, std::int64_t step,
               estimators::MeasurementBatch& batch) {
  // Geometry and draws are computed from the lower id's side so that both ends agree.
  const AgentId lo = std::min(agent, peer);
  const AgentId hi = std::max(agent, peer);
  const double doa_max = s.noise.doa_error_deg * std::numbers::pi / 180.0;
  auto doa_error = [&](std::uint64_t key) { return doa_max * (2.0 * core::unit_uniform(key) - 1.0); };
  for (std::size_t r = 0; r < world.walls.size(); ++r) {
    const auto path = models::reflect_path(world.truth[static_cast<std::size_t>(lo)],
                                           world.truth[static_cast<std::size_t>(hi)], world.walls[r]);
    if (!path) continue;  // the wall runs between the two: no reflection
    const auto index = static_cast<std::int64_t>(r);
    const double length = path->length_m + s.noise.range_std_m * core::standard_normal(noise_key(
                                                                     world, s, step, lo, hi, index, -3));
    const double theta_at_lo = path->theta_ji_rad + doa_error(noise_key(world, s, step, lo, hi, index, -4));
    const double theta_at_hi = path->theta_ij_rad + doa_error(noise_key(world, s, step, lo, hi, index, -5));
    const bool here_is_lo = agent == lo;
    batch.paths.push_back({peer, static_cast<int>(r), length, here_is_lo ? theta_at_lo : theta_at_hi,
                           here_is_lo ? theta_at_hi : theta_at_lo});
  }
}

/// Agent `agent`'s reading of the target, if it is within sensing range (world.hpp, generate_batch).
void add_target_reading(const World& world, const Scenario& s, AgentId agent, std::int64_t step,
                        estimators::MeasurementBatch& batch) {
  const Vec2 target = world.target.head<2>();
  const Vec2 offset = target - world.truth[static_cast<std::size_t>(agent)];
  const double distance = offset.norm();
  const double radius = s.world.target_sensing_radius_m;
  if (radius > 0.0 && distance > radius) return;
  const std::uint64_t key = noise_key(world, s, step, agent, -7);
  const Vec2 noise(core::standard_normal(key), core::standard_normal(key + 1));
  const double std_m = s.noise.target_std_m;
  if (s.world.target_sensing == config::TargetSensing::kLinear) {
    batch.targets.push_back({0, target + std_m * noise, Mat2::Identity() * std_m * std_m, 0});
    return;
  }
  if (distance < 1e-9) return;  // bearing undefined: the sensor sits on the target
  const double bearing_std = s.noise.target_bearing_std_rad;
  const Vec2 value(std::abs(distance + std_m * noise.x()),
                   models::wrap_angle(std::atan2(offset.y(), offset.x()) + bearing_std * noise.y()));
  const Mat2 covariance = Vec2(std_m * std_m, bearing_std * bearing_std).asDiagonal();
  batch.targets.push_back({0, value, covariance, 1});
}

}  // namespace

estimators::MeasurementBatch generate_batch(const World& world, const Scenario& s, AgentId agent,
                                            std::int64_t step) {
  if (world.recorded) return world.recorded->batch(agent, step);
  const MeasurementKinds kinds = measurement_kinds(s.algorithm.name);
  estimators::MeasurementBatch batch;
  batch.world_step = step;
  batch.world_time_s = static_cast<double>(step) / s.run.rate_hz;
  const auto i = static_cast<std::size_t>(agent);
  const Vec2& xi = world.truth[i];
  batch.neighbours = world.neighbours[i];
  for (AgentId j : world.neighbours[i]) {
    const double distance = world.distance(agent, j);
    if (distance > s.world.comm_radius_m) continue;  // moved out of range
    const AgentId lo = std::min(agent, j);
    const AgentId hi = std::max(agent, j);
    if (kinds.ranges) {
      const double std_m = s.noise.range_std_at(distance);
      const std::uint64_t key = s.noise.shared_range_draws ? noise_key(world, s, step, lo, hi, -2)
                                                           : noise_key(world, s, step, agent, j);
      batch.ranges.push_back({j, std::abs(distance + std_m * core::standard_normal(key)), std_m});
    }
    if (kinds.relative) {
      const std::uint64_t key = noise_key(world, s, step, lo, hi, -6);
      const Vec2 noise(core::standard_normal(key), core::standard_normal(key + 1));
      const Vec2 s_lo_hi = world.truth[static_cast<std::size_t>(hi)] -
                           world.truth[static_cast<std::size_t>(lo)] + s.noise.relative_std_m * noise;
      const double variance = s.noise.relative_std_m * s.noise.relative_std_m;
      batch.relative.push_back({j, agent == lo ? s_lo_hi : Vec2(-s_lo_hi), Mat2::Identity() * variance});
    }
    if (kinds.paths) add_paths(world, s, agent, j, step, batch);
  }
  if (kinds.anchor_fixes && world.is_anchor[i]) {
    estimators::AbsoluteFix fix;
    const auto fix_key = noise_key(world, s, step, agent, -1);
    fix.position_m = xi + s.noise.anchor_fix_std_m *
                              Vec2(core::standard_normal(fix_key), core::standard_normal(fix_key + 1));
    fix.covariance = Mat2::Identity() * s.noise.anchor_fix_std_m * s.noise.anchor_fix_std_m;
    if (world.dimensions == 3) {
      fix.z_m = world.altitude[i] + s.noise.anchor_fix_std_m * core::standard_normal(fix_key + 2);
    }
    batch.fix = fix;
  }
  if (kinds.targets) add_target_reading(world, s, agent, step, batch);
  if (kinds.field) {
    const double reading =
        estimators::consensus::field_observation_row(config::field_sensor(s), xi).dot(world.field) +
        s.noise.field_std * core::standard_normal(noise_key(world, s, step, agent, -8));
    const double variance = s.noise.field_std * s.noise.field_std;
    batch.targets.push_back(
        {0, Vec2(reading, 0.0), Vec2(variance, 1.0).asDiagonal(), estimators::consensus::kFieldReading});
  }
  return batch;
}

double reported_time_s(const Scenario& s, std::int64_t step) {
  if (s.world.source == config::WorldSource::kMrclam) return static_cast<double>(step) * s.world.data_step_s;
  return static_cast<double>(step) / s.run.rate_hz;
}

double absurd_position_bound_m(const Scenario& s) { return 1000.0 * std::max(1.0, s.world.area_m); }

}  // namespace swarmloc::world
