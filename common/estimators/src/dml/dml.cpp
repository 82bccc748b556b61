#include "swarmloc/estimators/dml/dml.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>

#include "dml/cavity.hpp"
#include "dml/rank_one_message.hpp"
#include "dml/thresholds.hpp"
#include "swarmloc/core/gaussian.hpp"
#include "swarmloc/estimators/dml/region.hpp"
#include "swarmloc/estimators/kalman/kernels.hpp"
#include "swarmloc/estimators/self_check.hpp"

namespace swarmloc::estimators {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
using dml_thresholds::kMirrorSeparationSigmas;
using dml_thresholds::kMultilaterationSpreadFraction;
using dml_thresholds::kSelfCheckFalseAlarm;
constexpr int kSolveIterations = 5;
constexpr double kLocalMapFalseAlarm = 1e-3;  // a local map that fits its ranges worse is folded
using rank_one::kShortestDistanceM;
using rank_one::message_scale;

/// An anchor that published a zero covariance (3-D: its altitude's too).
template <int D>
bool exactly_known(bool anchor, const MatD<D>& covariance) {
  return anchor && covariance.isZero();
}

/// The sender published a covariance: exactly known, or a belief (not the undefined one).
template <int D>
bool has_belief(bool anchor, const MatD<D>& covariance) {
  return exactly_known<D>(anchor, covariance) ||
         (dml_dimension::positive_definite_d<D>(covariance) && covariance.trace() < kUndefinedVarianceM2);
}

}  // namespace

using dml_cavity::cavity_variance;
using dml_cavity::far_cavity_variance;

template <int D>
double DmlT<D>::Edge::mean_range_m() const {
  const double total = information();
  return total > 0.0 ? (own_weighted_range + peer_information * peer_mean_range_m) / total : 0.0;
}

template <int D>
bool DmlT<D>::Edge::usable() const {
  return has_state && has_position && active && information() > 0.0 && mean_m.allFinite();
}

template <int D>
DmlT<D>::DmlT(const AgentSetup& setup, const KalmanFilterParams& /*params*/)
    : setup_(setup),
      x_(dml_dimension::position<D>(setup.initial_guess_m, setup.initial_altitude_m)),
      localized_(setup.anchor),
      two_hop_(setup.comm_radius_m) {
  if (!x_.allFinite()) throw std::invalid_argument("dml: initial guess is not finite");
  if (setup.dimensions != D)
    throw std::invalid_argument("dml: built for " + std::to_string(D) + " dimensions, the world has " +
                                std::to_string(setup.dimensions));
}

template <int D>
bool DmlT<D>::exact_anchor() const {
  return setup_.anchor && fix_information_.isZero();
}

template <int D>
void DmlT<D>::absorb_measurements(const MeasurementBatch& batch) {
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
    // A fix is planar: in 3-D it informs x and y only.
    const Mat2 fix_information = batch.fix->covariance.inverse();
    fix_information_.template topLeftCorner<2, 2>() += fix_information;
    fix_information_vector_.template head<2>() += fix_information * batch.fix->position_m;
  }
}

template <int D>
void DmlT<D>::absorb_states(const Inbox& inbox) {
  for (const auto& received : inbox.states) {
    if (received.sender == setup_.id) continue;
    Edge& edge = edges_[received.sender];
    edge.has_state = true;
    edge.active = received.message.active;
    edge.anchor = received.message.anchor;
    edge.inconsistent = received.message.inconsistent;
    edge.degree = received.message.degree;
    // A 3-D agent cannot use a state without an altitude: it keeps the planar part as a guess (local maps).
    const auto position = dml_dimension::read_state<D>(received.message);
    edge.has_position = position.has_value();
    edge.mean_m = position ? position->first : dml_dimension::position<D>(received.message.mean_m, 0.0);
    edge.covariance = position ? position->second : Mat(kUndefinedVarianceM2 * Mat::Identity());
    for (const auto& summary : received.message.edge_ranges) {
      if (summary.peer != setup_.id || !(summary.information > 0.0) || !std::isfinite(summary.mean_range_m))
        continue;
      edge.peer_information = summary.information;
      edge.peer_mean_range_m = summary.mean_range_m;
    }
    edge.cavity.reset();
    for (const auto& cavity : received.message.cavities) {
      if (cavity.peer != setup_.id) continue;
      Vec offset = dml_dimension::position<D>(cavity.offset_m, cavity.offset_z_m);
      if (offset.allFinite() && std::isfinite(cavity.variance_m2) && cavity.variance_m2 >= 0.0)
        edge.cavity = typename Edge::Cavity{offset, cavity.variance_m2};
    }
    if (!edge.has_position) continue;  // nor its summaries' peer positions
    if (received.message.active) two_hop_.absorb(setup_.id, edge.mean_m, received.message.edge_ranges);
    relays_.absorb(setup_.id, received.sender, edge.mean_m, received.message.edge_ranges);
  }
}

template <int D>
std::vector<typename DmlT<D>::Reference> DmlT<D>::references() const {
  std::vector<Reference> refs;
  for (const auto& [id, edge] : edges_) {
    if (edge.usable()) refs.push_back({id, edge.mean_m, edge.mean_range_m(), edge.information()});
  }
  return refs;
}

template <int D>
double DmlT<D>::local_cost(const Vec& x, const std::vector<Reference>& refs) const {
  double cost = x.dot(fix_information_ * x) - 2.0 * fix_information_vector_.dot(x);
  for (const auto& ref : refs) {
    const double residual = ref.mean_range_m - (x - ref.position_m).norm();
    cost += ref.information * residual * residual;
  }
  return cost;
}

template <int D>
typename DmlT<D>::Vec DmlT<D>::solve_position(Vec x, const std::vector<Reference>& refs) const {
  for (int iteration = 0; iteration < kSolveIterations; ++iteration) {
    Mat hessian = fix_information_;
    Vec gradient = fix_information_vector_ - fix_information_ * x;
    for (const auto& ref : refs) {
      const Vec offset = x - ref.position_m;
      const double distance = offset.norm();
      if (distance < kShortestDistanceM) continue;
      const Vec a = offset / distance;
      hessian += ref.information * a * a.transpose();
      gradient += ref.information * (ref.mean_range_m - distance) * a;
    }
    if (!dml_dimension::positive_definite_d<D>(hessian)) break;
    const Vec step = hessian.ldlt().solve(gradient);
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

template <int D>
std::optional<typename DmlT<D>::Vec> DmlT<D>::multilaterate(const std::vector<Reference>& refs) const {
  if (refs.size() < static_cast<std::size_t>(D + 1)) return std::nullopt;
  // Linear least squares on the differences of squared ranges to the first reference (row k:
  // 2(p_k − p_0)ᵀx = r_0² − r_k² + |p_k|² − |p_0|²), then refined on the ranges themselves.
  Mat normal = Mat::Zero();
  Vec rhs = Vec::Zero();
  Mat noise = Mat::Zero();  // Σ row rowᵀ var(value): the linear solution's spread is N⁻¹ (this) N⁻¹
  const Reference& base = refs.front();
  const double base_variance = 4.0 * base.mean_range_m * base.mean_range_m / base.information;
  for (std::size_t k = 1; k < refs.size(); ++k) {
    const Vec row = 2.0 * (refs[k].position_m - base.position_m);
    const double value = base.mean_range_m * base.mean_range_m - refs[k].mean_range_m * refs[k].mean_range_m +
                         refs[k].position_m.squaredNorm() - base.position_m.squaredNorm();
    normal += row * row.transpose();
    rhs += value * row;
    noise += row * row.transpose() *
             (base_variance + 4.0 * refs[k].mean_range_m * refs[k].mean_range_m / refs[k].information);
  }
  if (!dml_dimension::positive_definite_d<D>(normal)) return std::nullopt;
  const Mat inverse = normal.inverse();
  // Nearly collinear (coplanar) references (a mirror solution) or ranges too noisy for their geometry leave
  // the linear solution too uncertain to say which basin the position is in: wait for more neighbours.
  const double spread_m2 = Eigen::SelfAdjointEigenSolver<Mat>(inverse * noise * inverse).eigenvalues()(D - 1);
  double shortest_range_m = kInfinity;
  for (const auto& ref : refs) shortest_range_m = std::min(shortest_range_m, ref.mean_range_m);
  const double spread_fraction =
      D == 3 ? dml_thresholds::kMultilaterationSpreadFraction3d : kMultilaterationSpreadFraction;
  if (!(std::sqrt(spread_m2) < spread_fraction * shortest_range_m)) return std::nullopt;
  const Vec solution = solve_position(inverse * rhs, refs);
  if constexpr (D == 3) return unless_mirrored(solution, refs);
  return solution;
}

template <int D>
typename DmlT<D>::Vec DmlT<D>::on_continuum_nearest(const std::vector<Reference>& refs) const {
  const Reference& first = refs.front();
  const bool circle_of_two =
      D == 3 && refs.size() >= 2 && (refs[1].position_m - first.position_m).norm() >= kShortestDistanceM;
  if (!circle_of_two) {
    // One reference: a circle (2-D) or a sphere (3-D) about it.
    const Vec toward = x_ - first.position_m;
    const Vec direction = toward.norm() > kShortestDistanceM ? Vec(toward.normalized()) : Vec(Vec::UnitX());
    return first.position_m + first.mean_range_m * direction;
  }
  // Two references in 3-D: the circle where their spheres meet, about the line through them.
  const Reference& second = refs[1];
  const Vec baseline = second.position_m - first.position_m;
  const double separation = baseline.norm();
  const Vec e = baseline / separation;
  const double along = (first.mean_range_m * first.mean_range_m - second.mean_range_m * second.mean_range_m +
                        separation * separation) /
                       (2.0 * separation);
  const double across = std::sqrt(std::max(0.0, first.mean_range_m * first.mean_range_m - along * along));
  const Vec foot = first.position_m + along * e;
  Vec sideways = x_ - foot;
  sideways -= sideways.dot(e) * e;
  const Vec direction =
      sideways.norm() > kShortestDistanceM ? Vec(sideways.normalized()) : Vec(e.unitOrthogonal());
  return foot + across * direction;
}

template <int D>
std::optional<typename DmlT<D>::MirrorPair> DmlT<D>::mirror_pair(const std::vector<Reference>& refs) const {
  if (refs.size() < static_cast<std::size_t>(D)) return std::nullopt;
  const Reference& first = refs[0];
  const Reference& second = refs[1];
  const Vec baseline = second.position_m - first.position_m;
  const double separation = baseline.norm();
  if (separation < kShortestDistanceM) return std::nullopt;
  const Vec e = baseline / separation;
  const double along = (first.mean_range_m * first.mean_range_m - second.mean_range_m * second.mean_range_m +
                        separation * separation) /
                       (2.0 * separation);
  if constexpr (D == 2) {
    // The two points where the circles meet, either side of the line through the references.
    const double across = std::sqrt(std::max(0.0, first.mean_range_m * first.mean_range_m - along * along));
    const Vec2 foot = first.position_m + along * e;
    const Vec2 left = foot + across * Vec2(-e.y(), e.x());
    const Vec2 right = foot - across * Vec2(-e.y(), e.x());
    return MirrorPair{left, right, across, Hinge{first.id, second.id}};
  } else {
    // Three spheres: in the frame (e, f, n) of the references' plane the third fixes the coordinate along f,
    // and the two points lie either side of the plane (along n).
    const Reference& third = refs[2];
    const Vec to_third = third.position_m - first.position_m;
    const double third_along = e.dot(to_third);
    const Vec off_line = to_third - third_along * e;
    const double third_across = off_line.norm();
    if (third_across < kShortestDistanceM) return std::nullopt;
    const Vec f = off_line / third_across;
    const Vec n = e.cross(f);
    const double sideways =
        (first.mean_range_m * first.mean_range_m - third.mean_range_m * third.mean_range_m +
         third_along * third_along + third_across * third_across - 2.0 * third_along * along) /
        (2.0 * third_across);
    const double across = std::sqrt(
        std::max(0.0, first.mean_range_m * first.mean_range_m - along * along - sideways * sideways));
    const Vec foot = first.position_m + along * e + sideways * f;
    return MirrorPair{foot + across * n, foot - across * n, across, Hinge{first.id, second.id, third.id}};
  }
}

template <int D>
std::optional<typename DmlT<D>::GuessedStart> DmlT<D>::start_from_guess(
    const std::vector<Reference>& refs) const {
  if (refs.empty() || steps_ <= kInitializationPatienceSteps) return std::nullopt;
  const bool out_of_patience = steps_ > 3 * kInitializationPatienceSteps;
  const auto pair = mirror_pair(refs);
  if (!pair) {
    // Fewer than D references that span: a continuum the guess can only pick a point of.
    if (!out_of_patience) return std::nullopt;
    return GuessedStart{solve_position(on_continuum_nearest(refs), refs), true, std::nullopt};
  }
  // D references leave a mirror pair: the guess picks the one nearer to it if the pair is far apart for the
  // guess's uncertainty (or once waiting for one more reference has not helped).
  const Vec& left = pair->left;
  const Vec& right = pair->right;
  // The graph: a member that lands within the radius of an agent this one does not hear is impossible.
  if (const auto allowed = allowed_by_graph(left, right))
    return GuessedStart{solve_position(*allowed == 0 ? left : right, refs), false, pair->hinge};
  const Vec& nearer = (left - x_).norm() <= (right - x_).norm() ? left : right;
  bool distinguishable = 2.0 * pair->across > kMirrorSeparationSigmas * setup_.initial_guess_std_m;
  // 3-D: the guess decides only for a member it allows itself (a member far from it says a reference is off).
  if constexpr (D == 3)
    distinguishable = distinguishable && (nearer - x_).squaredNorm() <= dml_thresholds::guess_allowance() *
                                                                            setup_.initial_guess_std_m *
                                                                            setup_.initial_guess_std_m;
  if (!distinguishable && !out_of_patience) return std::nullopt;
  return GuessedStart{solve_position(nearer, refs), !distinguishable, pair->hinge};
}

template <int D>
typename DmlT<D>::LocalMap DmlT<D>::draw_local_map(bool beliefs_only) const {
  LocalMap map;
  map.nodes.push_back({false, x_});
  std::map<AgentId, int> index{{setup_.id, 0}};
  const auto add_node = [&](AgentId id, bool known, const Vec& position) {
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
    const bool known =
        edge.usable() && !edge.inconsistent && (!beliefs_only || has_belief<D>(edge.anchor, edge.covariance));
    add_range(0, add_node(id, known, edge.mean_m), edge.mean_range_m(), edge.information(),
              edge.peer_information > 0.0 ? 2 : 1);
    map.shortest_range_m = std::min(map.shortest_range_m, edge.mean_range_m());
  }
  // Agents two hops away enter only where a neighbour knows their position.
  relays_.for_each_range([&](AgentId, AgentId peer, double, double, const Vec* peer_mean) {
    if (peer_mean != nullptr) add_node(peer, true, *peer_mean);
  });
  relays_.for_each_range([&](AgentId via, AgentId peer, double range_m, double information, const Vec*) {
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

template <int D>
std::optional<typename DmlT<D>::Mat> DmlT<D>::map_covariance() const {
  const LocalMap map = draw_local_map(true);
  return local_map::covariance_at(map.nodes, map.ranges);
}

template <int D>
std::optional<local_map::PlacementT<D>> DmlT<D>::place_in_local_map(
    const std::vector<Reference>& refs) const {
  const LocalMap map = draw_local_map(false);
  // 3-D: the map's reflection need not reach the mirror image of the agent alone across its references'
  // plane; refined from there too, a mirror image that fits is seen (docs/algorithms.md §9.9).
  std::vector<Vec> agent_starts;
  double mirror_gap = 0.0;
  if constexpr (D == 3) {
    if (const auto pair = mirror_pair(refs)) agent_starts = {pair->left, pair->right};
    mirror_gap = dml_thresholds::mirror_gap();
  }
  return local_map::place(map.nodes, map.ranges, kLocalMapFalseAlarm,
                          kMultilaterationSpreadFraction * map.shortest_range_m, agent_starts, mirror_gap);
}

template <int D>
std::optional<typename DmlT<D>::MapStart> DmlT<D>::start_from_local_map(
    const std::vector<Reference>& refs) const {
  const auto mapped = place_in_local_map(refs);
  if (!mapped) return std::nullopt;
  if (!mapped->alternative_m) return MapStart{mapped->position_m, true};
  // Two maps fit the ranges: the graph may rule one out, as it does for a start from two references.
  if (const auto allowed = allowed_by_graph(mapped->position_m, *mapped->alternative_m))
    return MapStart{*allowed == 0 ? mapped->position_m : *mapped->alternative_m, true};
  const bool first_nearer = (mapped->position_m - x_).norm() <= (*mapped->alternative_m - x_).norm();
  return MapStart{first_nearer ? mapped->position_m : *mapped->alternative_m, false};
}

template <int D>
void DmlT<D>::start(const std::vector<Reference>& refs) {
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
    if (const auto mapped = start_from_local_map(refs); mapped && (mapped->decided || guessed)) {
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

template <int D>
double DmlT<D>::penetration(const Vec& x) const {
  return two_hop_.penetration(x, [this](AgentId id) { return id == setup_.id || edges_.contains(id); });
}

template <int D>
std::optional<int> DmlT<D>::allowed_by_graph(const Vec& first, const Vec& second) const {
  const double margin = two_hop_.margin_m();
  const double first_inside = impossibility(first);
  const double second_inside = impossibility(second);
  if (first_inside <= 0.0 && second_inside > margin) return 0;
  if (second_inside <= 0.0 && first_inside > margin) return 1;
  return std::nullopt;
}

template <int D>
double DmlT<D>::impossibility(const Vec& x) const {
  const double through_neighbours = relays_.violation(x, [this](AgentId via) {
    const auto edge = edges_.find(via);
    return edge != edges_.end() && edge->second.information() > 0.0 ? edge->second.mean_range_m() : -1.0;
  });
  // The truth meets a bound through a neighbour only to the ranges' noise (it can touch one when three
  // agents line up); the truth is never inside an unheard radius. Half a margin of slack keeps both apart.
  return std::max(penetration(x), through_neighbours - 0.5 * two_hop_.margin_m());
}

template <int D>
std::optional<typename DmlT<D>::Vec> DmlT<D>::mirror_of_current() const {
  if (!hinge_) return std::nullopt;
  std::array<Vec, static_cast<std::size_t>(D)> hinge_m;
  for (std::size_t k = 0; k < hinge_m.size(); ++k) {
    const auto edge = edges_.find((*hinge_)[k]);
    if (edge == edges_.end() || !edge->second.usable()) return std::nullopt;
    hinge_m[k] = edge->second.mean_m;
  }
  const Vec p = hinge_m[0];
  const Vec line = hinge_m[1] - p;
  if (line.norm() < kShortestDistanceM) return std::nullopt;
  const Vec offset = x_ - p;
  if constexpr (D == 2) {
    // Across the line through the two references.
    const Vec2 e = line.normalized();
    return Vec2(p + 2.0 * offset.dot(e) * e - offset);
  } else {
    // Across the plane through the three.
    const Vec normal = line.cross(hinge_m[2] - p);
    if (!(normal.norm() >= kShortestDistanceM * line.norm())) return std::nullopt;
    const Vec n = normal.normalized();
    return Vec(x_ - 2.0 * offset.dot(n) * n);
  }
}

template <int D>
void DmlT<D>::check_mirror() {
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

template <int D>
void DmlT<D>::update_information() {
  const bool have_belief = dml_dimension::positive_definite_d<D>(information_);
  const Mat covariance = have_belief ? Mat(information_.inverse()) : Mat(kInfinity * Mat::Identity());
  Mat information = fix_information_;
  for (auto& [id, edge] : edges_) {
    const Vec offset = x_ - edge.mean_m;
    if (!edge.usable() || offset.norm() < kShortestDistanceM) {
      edge.message_scale = 0.0;
      continue;
    }
    const Vec a = offset.normalized();
    // What this agent told the neighbour (its belief without the neighbour's message), then the
    // neighbour's belief without that: the cavity, so no range is counted twice around the edge.
    const double sent_scale = message_scale(
        edge.information(), have_belief ? cavity_variance<D>(covariance, a, edge.message_scale) : kInfinity);
    // The neighbour's own cavity variance when it sent one; otherwise taken out of its belief here.
    double far_variance = 0.0;
    if (!exactly_known<D>(edge.anchor, edge.covariance)) {
      far_variance = edge.cavity ? edge.cavity->variance_m2
                                 : far_cavity_variance<D>(edge.covariance, a, sent_scale, edge.sent_scale);
    }
    edge.message_scale = message_scale(edge.information(), far_variance);
    edge.sent_scale = sent_scale;
    information += edge.message_scale * a * a.transpose();
  }
  information_ = information;
}

template <int D>
std::optional<typename DmlT<D>::Mat> DmlT<D>::region_covariance() const {
  std::vector<region::MemberT<D>> members;
  std::vector<AgentId> member_ids;
  std::vector<region::KnownT<D>> known;
  for (const auto& [id, edge] : edges_) {
    if (!edge.usable()) continue;
    if (exactly_known<D>(edge.anchor, edge.covariance)) {
      known.push_back({edge.mean_m, edge.information()});
    } else {
      members.push_back({edge.mean_m, edge.covariance, edge.information(), edge.sent_scale,
                         edge.anchor ? std::size_t{0} : std::size_t{edge.degree}});
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
  return region::centre_covariance<D>(x_, fix_information_, members, links, known);
}

template <int D>
double DmlT<D>::residual_statistic(int& degrees_of_freedom) const {
  degrees_of_freedom = 0;
  if (!dml_dimension::positive_definite_d<D>(information_)) return 0.0;
  const Mat covariance = information_.inverse();
  double statistic = 0.0;
  for (const auto& [id, edge] : edges_) {
    const Vec offset = x_ - edge.mean_m;
    if (!edge.usable() || offset.norm() < kShortestDistanceM) continue;
    const Vec a = offset.normalized();
    const double far_variance =
        exactly_known<D>(edge.anchor, edge.covariance) ? 0.0 : a.dot(edge.covariance * a);
    if (!std::isfinite(far_variance)) continue;
    const double variance = 1.0 / edge.information() + a.dot(covariance * a) + far_variance;
    const double residual = edge.mean_range_m() - offset.norm();
    statistic += residual * residual / variance;
    ++degrees_of_freedom;
  }
  return statistic;
}

template <int D>
bool DmlT<D>::leans_on_flagged_neighbours(const std::vector<Reference>& refs) const {
  std::size_t flagged = 0;
  for (const auto& ref : refs) {
    if (edges_.at(ref.id).inconsistent) ++flagged;
  }
  // D + 1 references fix a position; fewer unflagged ones leave it resting on the flagged.
  return flagged > 0 && refs.size() - flagged < static_cast<std::size_t>(D + 1);
}

template <int D>
StepOutput DmlT<D>::step(const StepInput& input) {
  StepOutput out;
  ++steps_;
  if (input.measurements != nullptr) absorb_measurements(*input.measurements);
  if (input.inbox != nullptr) absorb_states(*input.inbox);
  if (exact_anchor()) {
    x_ = dml_dimension::position<D>(setup_.initial_guess_m, setup_.initial_altitude_m);
    out.outbox = published();
    return out;
  }
  const auto refs = references();
  if (!localized_) start(refs);
  if (localized_) {
    if (hinge_) check_mirror();
    // Belief propagation's mean once the agent has a belief; until then, the neighbours' means as they are.
    x_ =
        solve_position(x_, dml_dimension::positive_definite_d<D>(information_) ? message_references() : refs);
    update_information();
    // Belief propagation leaves an agent without a belief where its neighbours have none either (a group
    // rigid only with agents two hops away): its local map gives the covariance then.
    reported_covariance_ =
        dml_dimension::positive_definite_d<D>(information_) ? region_covariance() : map_covariance();
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

template <int D>
typename DmlT<D>::Mat DmlT<D>::published_covariance() const {
  if (exact_anchor()) return Mat::Zero();
  if (localized_ && dml_dimension::positive_definite_d<D>(information_))
    return dml_dimension::symmetrized_d<D>(information_.inverse());
  return kUndefinedVarianceM2 * Mat::Identity();
}

template <int D>
StateMessage DmlT<D>::state_message() const {
  StateMessage state;
  dml_dimension::write_state<D>(x_, published_covariance(), state);
  state.anchor = setup_.anchor;
  state.active = localized_;
  state.inconsistent = inconsistent_ || ambiguous_start_;
  state.degree = static_cast<std::uint16_t>(std::min<std::size_t>(edges_.size(), UINT16_MAX));
  return state;
}

template <int D>
Outbox DmlT<D>::initial_outbox() const {
  Outbox outbox;
  outbox.state = state_message();
  return outbox;
}

template <int D>
Outbox DmlT<D>::published() {
  StateMessage state = state_message();
  std::vector<AgentId> measured;
  for (const auto& [id, edge] : edges_) {
    if (edge.own_information > 0.0) measured.push_back(id);
  }
  for (std::size_t k = 0; k < std::min(kSummariesPerMessage, measured.size()); ++k) {
    const AgentId peer = measured[(summary_cursor_ + k) % measured.size()];
    const Edge& edge = edges_.at(peer);
    // The peer's mean rides along for the receivers' negative connectivity; this agent's own: not known.
    state.edge_ranges.push_back(dml_dimension::summary<D>(peer, edge.own_information,
                                                          edge.own_weighted_range / edge.own_information,
                                                          edge.usable() ? edge.mean_m : x_));
  }
  summary_cursor_ += kSummariesPerMessage;
  state.cavities = cavities();
  Outbox outbox;
  outbox.state = std::move(state);
  return outbox;
}

template <int D>
Estimate DmlT<D>::estimate() const {
  Estimate estimate;
  dml_dimension::write_estimate<D>(x_, reported_covariance_.value_or(published_covariance()), estimate);
  estimate.valid =
      exact_anchor() ||
      (localized_ && (dml_dimension::positive_definite_d<D>(information_) || reported_covariance_));
  estimate.inconsistent = inconsistent_ || ambiguous_start_ || doubtful_support_;
  return estimate;
}

template class DmlT<2>;
template class DmlT<3>;

}  // namespace swarmloc::estimators
