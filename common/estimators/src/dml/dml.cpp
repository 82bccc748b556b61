#include "swarmloc/estimators/dml/dml.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <utility>

#include "dml/rank_one_message.hpp"
#include "swarmloc/core/gaussian.hpp"
#include "swarmloc/estimators/dml/region.hpp"
#include "swarmloc/estimators/kalman/kernels.hpp"
#include "swarmloc/estimators/self_check.hpp"

namespace swarmloc::estimators {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr double kSelfCheckFalseAlarm = 1e-6;    // per agent and step: a healthy network never flags
constexpr double kMirrorSeparationSigmas = 6.0;  // a mirror pair the guess tells apart: 3σ on each side
constexpr double kMultilaterationSpreadFraction = 0.1;  // its std, as a fraction of the shortest range
constexpr int kSolveIterations = 5;
constexpr double kMessageAbsentRatio = 2.0;   // s·q beyond this: the neighbour's belief lacks the message
constexpr double kLocalMapFalseAlarm = 1e-3;  // a local map that fits its ranges worse is folded
using rank_one::kCavityTolerance;
using rank_one::kShortestDistanceM;
using rank_one::message_scale;

/// a^T P a for the variance of position `covariance` along unit vector `a`, after the rank-one message
/// s·aaᵀ is taken out of its information (Sherman–Morrison): q / (1 − s q), +inf if nothing is left.
double cavity_variance(const Mat2& covariance, const Vec2& a, double message_scale) {
  const double q = a.dot(covariance * a);
  if (!std::isfinite(q)) return kInfinity;
  const double remaining = 1.0 - message_scale * q;
  return remaining > kCavityTolerance ? q / remaining : kInfinity;
}

/// The neighbour's variance along `a` without the message this agent sent it (`sent_scale`, or the one of the
/// step before, `previous_sent_scale`, which the neighbour's last belief may hold instead). A belief that
/// holds s·aaᵀ has s·q < 1 (Sherman–Morrison); well above 1 for both, the neighbour formed its belief without
/// either (it heard this agent while this agent's belief was undefined): nothing is there to take out
/// (docs/algorithms.md §9.3).
double far_cavity_variance(const Mat2& covariance, const Vec2& a, double sent_scale,
                           double previous_sent_scale) {
  const double q = a.dot(covariance * a);
  if (!std::isfinite(q)) return kInfinity;
  for (const double scale : {sent_scale, previous_sent_scale}) {
    const double remaining = 1.0 - scale * q;
    if (remaining > kCavityTolerance) return q / remaining;
  }
  if (std::min(sent_scale, previous_sent_scale) * q > kMessageAbsentRatio) return q;
  return kInfinity;
}

bool exactly_known(const StateMessage& state) { return state.anchor && state.covariance.isZero(); }

/// The sender published a covariance: exactly known, or a belief (not the undefined one).
bool has_belief(const StateMessage& state) {
  return exactly_known(state) ||
         (positive_definite(state.covariance) && state.covariance.trace() < kUndefinedVarianceM2);
}

}  // namespace

double Dml::Edge::mean_range_m() const {
  const double total = information();
  return total > 0.0 ? (own_weighted_range + peer_information * peer_mean_range_m) / total : 0.0;
}

bool Dml::Edge::usable() const {
  return has_state && state.active && information() > 0.0 && state.mean_m.allFinite();
}

Dml::Dml(const AgentSetup& setup, const KalmanFilterParams& /*params*/)
    : setup_(setup), x_(setup.initial_guess_m), localized_(setup.anchor), two_hop_(setup.comm_radius_m) {
  if (!setup.initial_guess_m.allFinite()) throw std::invalid_argument("dml: initial guess is not finite");
}

bool Dml::exact_anchor() const { return setup_.anchor && fix_information_.isZero(); }

void Dml::absorb_measurements(const MeasurementBatch& batch) {
  for (const auto& range : batch.ranges) {
    if (range.peer == setup_.id || !(range.std_m > 0.0) || !std::isfinite(range.range_m)) continue;
    const double information = 1.0 / (range.std_m * range.std_m);
    Edge& edge = edges_[range.peer];
    // A reading identical to the last one to the same peer, bit for bit, is the same draw again (a sensor
    // that repeats its value, noise.draw: once): it adds no information.
    if (edge.own_information > 0.0 && range.range_m == edge.last_range_m) continue;
    edge.last_range_m = range.range_m;
    edge.own_information += information;
    edge.own_weighted_range += information * range.range_m;
  }
  if (batch.fix && positive_definite(batch.fix->covariance) && batch.fix->position_m.allFinite()) {
    const Mat2 fix_information = batch.fix->covariance.inverse();
    fix_information_ += fix_information;
    fix_information_vector_ += fix_information * batch.fix->position_m;
  }
}

void Dml::absorb_states(const Inbox& inbox) {
  for (const auto& received : inbox.states) {
    if (received.sender == setup_.id) continue;
    Edge& edge = edges_[received.sender];
    edge.has_state = true;
    edge.state = received.message;
    for (const auto& summary : received.message.edge_ranges) {
      if (summary.peer != setup_.id || !(summary.information > 0.0) || !std::isfinite(summary.mean_range_m))
        continue;
      edge.peer_information = summary.information;
      edge.peer_mean_range_m = summary.mean_range_m;
    }
    if (received.message.active)
      two_hop_.absorb(setup_.id, received.message.mean_m, received.message.edge_ranges);
    relays_.absorb(setup_.id, received.sender, received.message.mean_m, received.message.edge_ranges);
  }
}

std::vector<Dml::Reference> Dml::references() const {
  std::vector<Reference> refs;
  for (const auto& [id, edge] : edges_) {
    if (edge.usable()) refs.push_back({id, edge.state.mean_m, edge.mean_range_m(), edge.information()});
  }
  return refs;
}

double Dml::local_cost(const Vec2& x, const std::vector<Reference>& refs) const {
  double cost = x.dot(fix_information_ * x) - 2.0 * fix_information_vector_.dot(x);
  for (const auto& ref : refs) {
    const double residual = ref.mean_range_m - (x - ref.position_m).norm();
    cost += ref.information * residual * residual;
  }
  return cost;
}

Vec2 Dml::solve_position(Vec2 x, const std::vector<Reference>& refs) const {
  for (int iteration = 0; iteration < kSolveIterations; ++iteration) {
    Mat2 hessian = fix_information_;
    Vec2 gradient = fix_information_vector_ - fix_information_ * x;
    for (const auto& ref : refs) {
      const Vec2 offset = x - ref.position_m;
      const double distance = offset.norm();
      if (distance < kShortestDistanceM) continue;
      const Vec2 a = offset / distance;
      hessian += ref.information * a * a.transpose();
      gradient += ref.information * (ref.mean_range_m - distance) * a;
    }
    if (!positive_definite(hessian)) break;
    const Vec2 step = hessian.ldlt().solve(gradient);
    // Backtrack so a step never raises the local cost (the Gauss–Newton step can overshoot far from x).
    const double cost = local_cost(x, refs);
    double fraction = 1.0;
    while (fraction > 1.0 / 64.0 && local_cost(x + fraction * step, refs) > cost) fraction *= 0.5;
    if (local_cost(x + fraction * step, refs) > cost) break;
    x += fraction * step;
    if ((fraction * step).norm() < 1e-12) break;
  }
  return x;
}

std::optional<Vec2> Dml::multilaterate(const std::vector<Reference>& refs) const {
  if (refs.size() < 3) return std::nullopt;
  // Linear least squares on the differences of squared ranges to the first reference (row k:
  // 2(p_k − p_0)ᵀx = r_0² − r_k² + |p_k|² − |p_0|²), then refined on the ranges themselves.
  Mat2 normal = Mat2::Zero();
  Vec2 rhs = Vec2::Zero();
  Mat2 noise = Mat2::Zero();  // Σ row rowᵀ var(value): the linear solution's spread is N⁻¹ (this) N⁻¹
  const Reference& base = refs.front();
  const double base_variance = 4.0 * base.mean_range_m * base.mean_range_m / base.information;
  for (std::size_t k = 1; k < refs.size(); ++k) {
    const Vec2 row = 2.0 * (refs[k].position_m - base.position_m);
    const double value = base.mean_range_m * base.mean_range_m - refs[k].mean_range_m * refs[k].mean_range_m +
                         refs[k].position_m.squaredNorm() - base.position_m.squaredNorm();
    normal += row * row.transpose();
    rhs += value * row;
    noise += row * row.transpose() *
             (base_variance + 4.0 * refs[k].mean_range_m * refs[k].mean_range_m / refs[k].information);
  }
  if (!positive_definite(normal)) return std::nullopt;
  const Mat2 inverse = normal.inverse();
  // Nearly collinear references (a mirror solution) or ranges too noisy for their geometry leave the
  // linear solution too uncertain to say which basin the position is in: wait for more neighbours.
  const double spread_m2 = Eigen::SelfAdjointEigenSolver<Mat2>(inverse * noise * inverse).eigenvalues()(1);
  double shortest_range_m = kInfinity;
  for (const auto& ref : refs) shortest_range_m = std::min(shortest_range_m, ref.mean_range_m);
  if (!(std::sqrt(spread_m2) < kMultilaterationSpreadFraction * shortest_range_m)) return std::nullopt;
  return solve_position(inverse * rhs, refs);
}

std::optional<Dml::GuessedStart> Dml::start_from_guess(const std::vector<Reference>& refs) const {
  if (refs.empty() || steps_ <= kInitializationPatienceSteps) return std::nullopt;
  const bool out_of_patience = steps_ > 3 * kInitializationPatienceSteps;
  const Reference& first = refs.front();
  if (refs.size() == 1 || (refs[1].position_m - first.position_m).norm() < kShortestDistanceM) {
    if (!out_of_patience) return std::nullopt;  // a whole circle: the guess can only pick a point of it
    const Vec2 toward = x_ - first.position_m;
    const Vec2 direction =
        toward.norm() > kShortestDistanceM ? Vec2(toward.normalized()) : Vec2(Vec2::UnitX());
    return GuessedStart{solve_position(first.position_m + first.mean_range_m * direction, refs), true,
                        std::nullopt};
  }
  // Two references leave a mirror pair: the guess picks the one nearer to it if the pair is far apart
  // for the guess's uncertainty (or once waiting for a third reference has not helped).
  const Reference& second = refs[1];
  const Vec2 baseline = second.position_m - first.position_m;
  const double separation = baseline.norm();
  const double along = (first.mean_range_m * first.mean_range_m - second.mean_range_m * second.mean_range_m +
                        separation * separation) /
                       (2.0 * separation);
  const double across = std::sqrt(std::max(0.0, first.mean_range_m * first.mean_range_m - along * along));
  const Vec2 e = baseline / separation;
  const Vec2 foot = first.position_m + along * e;
  const Vec2 left = foot + across * Vec2(-e.y(), e.x());
  const Vec2 right = foot - across * Vec2(-e.y(), e.x());
  const auto hinge = std::pair{first.id, second.id};
  // The graph: a member that lands within the radius of an agent this one does not hear is impossible.
  if (const auto allowed = allowed_by_graph(left, right))
    return GuessedStart{solve_position(*allowed == 0 ? left : right, refs), false, hinge};
  const bool distinguishable = 2.0 * across > kMirrorSeparationSigmas * setup_.initial_guess_std_m;
  if (!distinguishable && !out_of_patience) return std::nullopt;
  return GuessedStart{solve_position((left - x_).norm() <= (right - x_).norm() ? left : right, refs),
                      !distinguishable, hinge};
}

Dml::LocalMap Dml::draw_local_map(bool beliefs_only) const {
  LocalMap map;
  map.nodes.push_back({false, x_});
  std::map<AgentId, int> index{{setup_.id, 0}};
  const auto add_node = [&](AgentId id, bool known, const Vec2& position) {
    const auto [at, added] = index.emplace(id, static_cast<int>(map.nodes.size()));
    if (added) map.nodes.push_back({known, position});
    return at->second;
  };
  struct Sums {
    double information = 0.0;
    double weighted_range = 0.0;  // Σ W·r
    int halves = 0;               // the ends whose draws are in (each relays only its own)
  };
  std::map<std::pair<int, int>, Sums> pairs;
  const auto add_range = [&pairs](int a, int b, double range_m, double information, int halves) {
    Sums& sums = pairs[std::minmax(a, b)];
    sums.information += information;
    sums.weighted_range += information * range_m;
    sums.halves += halves;
  };
  for (const auto& [id, edge] : edges_) {
    if (!(edge.information() > 0.0)) continue;
    if (beliefs_only && !edge.usable()) continue;  // no place to linearize at
    // A neighbour's own flag puts its position in doubt: the map places it instead of holding it.
    const bool known = edge.usable() && !edge.state.inconsistent && (!beliefs_only || has_belief(edge.state));
    add_range(0, add_node(id, known, edge.state.mean_m), edge.mean_range_m(), edge.information(),
              edge.peer_information > 0.0 ? 2 : 1);
    map.shortest_range_m = std::min(map.shortest_range_m, edge.mean_range_m());
  }
  // Agents two hops away enter only where a neighbour knows their position.
  relays_.for_each_range([&](AgentId, AgentId peer, double, double, const Vec2* peer_mean) {
    if (peer_mean != nullptr) add_node(peer, true, *peer_mean);
  });
  relays_.for_each_range([&](AgentId via, AgentId peer, double range_m, double information, const Vec2*) {
    const auto from = index.find(via);
    const auto to = index.find(peer);
    if (from != index.end() && to != index.end())
      add_range(from->second, to->second, range_m, information, 1);
  });
  map.ranges.reserve(pairs.size());
  for (const auto& [ends, sums] : pairs) {
    // For the covariance, one end's draws stand for both (the other end relays to its own neighbours only),
    // as in the region correction (§9.3); the start's map keeps what it has.
    const double scale = beliefs_only && sums.halves == 1 ? 2.0 : 1.0;
    map.ranges.push_back(
        {ends.first, ends.second, sums.weighted_range / sums.information, scale * sums.information});
  }
  return map;
}

std::optional<Mat2> Dml::map_covariance() const {
  const LocalMap map = draw_local_map(true);
  return local_map::covariance_at(map.nodes, map.ranges);
}

std::optional<local_map::Placement> Dml::place_in_local_map() const {
  const LocalMap map = draw_local_map(false);
  return local_map::place(map.nodes, map.ranges, kLocalMapFalseAlarm,
                          kMultilaterationSpreadFraction * map.shortest_range_m);
}

std::optional<Dml::MapStart> Dml::start_from_local_map() const {
  const auto mapped = place_in_local_map();
  if (!mapped) return std::nullopt;
  if (!mapped->alternative_m) return MapStart{mapped->position_m, true};
  // Two maps fit the ranges: the graph may rule one out, as it does for a start from two references.
  if (const auto allowed = allowed_by_graph(mapped->position_m, *mapped->alternative_m))
    return MapStart{*allowed == 0 ? mapped->position_m : *mapped->alternative_m, true};
  const bool first_nearer = (mapped->position_m - x_).norm() <= (*mapped->alternative_m - x_).norm();
  return MapStart{first_nearer ? mapped->position_m : *mapped->alternative_m, false};
}

void Dml::start(const std::vector<Reference>& refs) {
  if (const auto multilaterated = multilaterate(refs)) {
    x_ = *multilaterated;
    localized_ = true;
    return;
  }
  const auto guessed = start_from_guess(refs);
  if (steps_ > kInitializationPatienceSteps && (!guessed || guessed->ambiguous)) {
    // The wave has not reached this agent, or reached it from one side only: its neighbourhood's map may
    // fix it where no single neighbour's ranges do. An undecided map still fits every range of the
    // neighbourhood: when the guess has to pick now, it picks between the map's two places, not a point on
    // one reference's circle.
    if (const auto mapped = start_from_local_map(); mapped && (mapped->decided || guessed)) {
      x_ = solve_position(mapped->position_m, refs);
      ambiguous_start_ = !mapped->decided;
      hinge_.reset();
      localized_ = true;
      return;
    }
  }
  if (guessed) {
    x_ = guessed->position_m;
    ambiguous_start_ = guessed->ambiguous;
    hinge_ = guessed->hinge;
    localized_ = true;  // the self-check watches a start the ranges alone could not fix
  }
}

double Dml::penetration(const Vec2& x) const {
  return two_hop_.penetration(x, [this](AgentId id) { return id == setup_.id || edges_.contains(id); });
}

std::optional<int> Dml::allowed_by_graph(const Vec2& first, const Vec2& second) const {
  const double margin = two_hop_.margin_m();
  const double first_inside = impossibility(first);
  const double second_inside = impossibility(second);
  if (first_inside <= 0.0 && second_inside > margin) return 0;
  if (second_inside <= 0.0 && first_inside > margin) return 1;
  return std::nullopt;
}

double Dml::impossibility(const Vec2& x) const {
  const double through_neighbours = relays_.violation(x, [this](AgentId via) {
    const auto edge = edges_.find(via);
    return edge != edges_.end() && edge->second.information() > 0.0 ? edge->second.mean_range_m() : -1.0;
  });
  // The truth meets a bound through a neighbour only to the ranges' noise (it can touch one when three
  // agents line up); the truth is never inside an unheard radius. Half a margin of slack keeps both apart.
  return std::max(penetration(x), through_neighbours - 0.5 * two_hop_.margin_m());
}

std::optional<Vec2> Dml::mirror_of_current() const {
  if (!hinge_) return std::nullopt;
  const auto a = edges_.find(hinge_->first);
  const auto b = edges_.find(hinge_->second);
  if (a == edges_.end() || b == edges_.end() || !a->second.usable() || !b->second.usable())
    return std::nullopt;
  const Vec2 p = a->second.state.mean_m;
  const Vec2 line = b->second.state.mean_m - p;
  if (line.norm() < kShortestDistanceM) return std::nullopt;
  const Vec2 e = line.normalized();
  const Vec2 offset = x_ - p;
  return Vec2(p + 2.0 * offset.dot(e) * e - offset);
}

void Dml::check_mirror() {
  // A start from two references: the graph may tell the pair apart once more of it is known. It confirms
  // the start (the mirror image is impossible), or moves the agent to the mirror image (this one is).
  const auto mirror = mirror_of_current();
  if (!mirror) return;
  const auto allowed = allowed_by_graph(x_, *mirror);
  if (!allowed) return;
  if (*allowed == 1) x_ = solve_position(*mirror, references());
  ambiguous_start_ = false;
  hinge_.reset();
}

void Dml::update_information() {
  const bool have_belief = positive_definite(information_);
  const Mat2 covariance = have_belief ? Mat2(information_.inverse()) : Mat2(kInfinity * Mat2::Identity());
  Mat2 information = fix_information_;
  for (auto& [id, edge] : edges_) {
    const Vec2 offset = x_ - edge.state.mean_m;
    if (!edge.usable() || offset.norm() < kShortestDistanceM) {
      edge.message_scale = 0.0;
      continue;
    }
    const Vec2 a = offset.normalized();
    // What this agent told the neighbour (its belief without the neighbour's message), then the
    // neighbour's belief without that: the cavity, so no range is counted twice around the edge.
    const double sent_scale = message_scale(
        edge.information(), have_belief ? cavity_variance(covariance, a, edge.message_scale) : kInfinity);
    const double far_variance = exactly_known(edge.state) ? 0.0
                                                          : far_cavity_variance(edge.state.covariance, a,
                                                                                sent_scale, edge.sent_scale);
    edge.message_scale = message_scale(edge.information(), far_variance);
    edge.sent_scale = sent_scale;
    information += edge.message_scale * a * a.transpose();
  }
  information_ = information;
}

std::optional<Mat2> Dml::region_covariance() const {
  std::vector<region::Member> members;
  std::vector<AgentId> member_ids;
  std::vector<region::Known> known;
  for (const auto& [id, edge] : edges_) {
    if (!edge.usable()) continue;
    if (exactly_known(edge.state)) {
      known.push_back({edge.state.mean_m, edge.information()});
    } else {
      members.push_back({edge.state.mean_m, edge.state.covariance, edge.information(), edge.sent_scale,
                         edge.state.anchor ? std::size_t{0} : std::size_t{edge.state.degree}});
      member_ids.push_back(id);
    }
  }
  // What each member relayed of its own draws of its ranges to the others (member_ids are ascending).
  MatX halves =
      MatX::Zero(static_cast<Eigen::Index>(members.size()), static_cast<Eigen::Index>(members.size()));
  relays_.for_each_information_among(member_ids, [&halves](std::size_t p, std::size_t q, double information) {
    halves(static_cast<Eigen::Index>(p), static_cast<Eigen::Index>(q)) = information;
  });
  std::vector<region::Link> links;
  for (Eigen::Index p = 0; p < halves.rows(); ++p) {
    for (Eigen::Index q = p + 1; q < halves.rows(); ++q) {
      // Each end relays its own draws of the range; one end's alone stands for both (equal draws).
      const double from_p = halves(p, q);
      const double from_q = halves(q, p);
      const double information =
          from_p > 0.0 && from_q > 0.0 ? from_p + from_q : 2.0 * std::max(from_p, from_q);
      if (information > 0.0)
        links.push_back({static_cast<std::size_t>(p), static_cast<std::size_t>(q), information});
    }
  }
  return region::centre_covariance(x_, fix_information_, members, links, known);
}

double Dml::residual_statistic(int& degrees_of_freedom) const {
  degrees_of_freedom = 0;
  if (!positive_definite(information_)) return 0.0;
  const Mat2 covariance = information_.inverse();
  double statistic = 0.0;
  for (const auto& [id, edge] : edges_) {
    const Vec2 offset = x_ - edge.state.mean_m;
    if (!edge.usable() || offset.norm() < kShortestDistanceM) continue;
    const Vec2 a = offset.normalized();
    const double far_variance = exactly_known(edge.state) ? 0.0 : a.dot(edge.state.covariance * a);
    if (!std::isfinite(far_variance)) continue;
    const double variance = 1.0 / edge.information() + a.dot(covariance * a) + far_variance;
    const double residual = edge.mean_range_m() - offset.norm();
    statistic += residual * residual / variance;
    ++degrees_of_freedom;
  }
  return statistic;
}

bool Dml::leans_on_flagged_neighbours(const std::vector<Reference>& refs) const {
  std::size_t flagged = 0;
  for (const auto& ref : refs) {
    if (edges_.at(ref.id).state.inconsistent) ++flagged;
  }
  // Three references fix a position in the plane; fewer unflagged ones leave it resting on the flagged.
  return flagged > 0 && refs.size() - flagged < 3;
}

StepOutput Dml::step(const StepInput& input) {
  StepOutput out;
  ++steps_;
  if (input.measurements != nullptr) absorb_measurements(*input.measurements);
  if (input.inbox != nullptr) absorb_states(*input.inbox);
  if (exact_anchor()) {
    x_ = setup_.initial_guess_m;
    out.outbox = published();
    return out;
  }
  const auto refs = references();
  if (!localized_) start(refs);
  if (localized_) {
    if (hinge_) check_mirror();
    x_ = solve_position(x_, refs);
    update_information();
    // Belief propagation leaves an agent without a belief where its neighbours have none either (a group
    // rigid only with agents two hops away): its local map gives the covariance then.
    reported_covariance_ = positive_definite(information_) ? region_covariance() : map_covariance();
    int dof = 0;
    const double statistic = residual_statistic(dof);
    inconsistent_ = (dof > 0 && statistic > chi_square_upper_quantile(dof, kSelfCheckFalseAlarm)) ||
                    impossibility(x_) > two_hop_.margin_m();
    if (inconsistent_) {
      // Likely a wrong basin: restart from a multilateration if that explains the data better.
      if (const auto restart = multilaterate(refs);
          restart && local_cost(*restart, refs) < local_cost(x_, refs)) {
        x_ = *restart;
      }
    }
    doubtful_support_ = leans_on_flagged_neighbours(refs);
    out.diagnostics.updated = true;
  }
  out.diagnostics.neighbours_used = static_cast<int>(refs.size());
  out.outbox = published();
  return out;
}

StateMessage Dml::state_message() const {
  StateMessage state;
  state.mean_m = x_;
  state.anchor = setup_.anchor;
  state.active = localized_;
  state.inconsistent = inconsistent_ || ambiguous_start_;
  if (exact_anchor()) {
    state.covariance = Mat2::Zero();
  } else if (localized_ && positive_definite(information_)) {
    state.covariance = core::symmetrized(information_.inverse());
  } else {
    state.covariance = kUndefinedVarianceM2 * Mat2::Identity();
  }
  state.degree = static_cast<std::uint16_t>(std::min<std::size_t>(edges_.size(), UINT16_MAX));
  return state;
}

Outbox Dml::initial_outbox() const {
  Outbox outbox;
  outbox.state = state_message();
  return outbox;
}

Outbox Dml::published() {
  StateMessage state = state_message();
  std::vector<AgentId> measured;
  for (const auto& [id, edge] : edges_) {
    if (edge.own_information > 0.0) measured.push_back(id);
  }
  for (std::size_t k = 0; k < std::min(kSummariesPerMessage, measured.size()); ++k) {
    const AgentId peer = measured[(summary_cursor_ + k) % measured.size()];
    const Edge& edge = edges_.at(peer);
    // The peer's mean rides along for the receivers' negative connectivity; this agent's own: not known.
    state.edge_ranges.push_back({peer, edge.own_information, edge.own_weighted_range / edge.own_information,
                                 edge.usable() ? edge.state.mean_m : state.mean_m});
  }
  summary_cursor_ += kSummariesPerMessage;
  Outbox outbox;
  outbox.state = std::move(state);
  return outbox;
}

Estimate Dml::estimate() const {
  Estimate estimate;
  estimate.mean_m = x_;
  const StateMessage state = state_message();
  estimate.covariance = reported_covariance_.value_or(state.covariance);
  estimate.valid =
      exact_anchor() || (localized_ && (positive_definite(information_) || reported_covariance_));
  estimate.inconsistent = inconsistent_ || ambiguous_start_ || doubtful_support_;
  return estimate;
}

}  // namespace swarmloc::estimators
