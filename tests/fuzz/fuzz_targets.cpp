// Seeded random-mutation fuzz targets (see fuzz_targets.hpp).
//
// Decoders: a valid sample is built through the writer path (Wire* in convert.hpp), then 0–5 mutations
// hit it: a field set to NaN, ±Inf, ±DBL_MAX, a denormal, a huge or random-bit value; an integer or enum
// set to a boundary or random value; a sequence given another length (empty, at/over its IDL bound,
// random, very long) with random contents, or a null buffer with a non-zero length; or the whole struct
// overwritten with random bytes (sequences and bools re-pointed/re-set afterwards, since CDR
// deserialization cannot produce a wild pointer or a bool other than 0/1). Contract checked:
//   - the decoder never crashes, and its well_formed flag is exactly the documented structural rule;
//   - a well-formed sample carries the wire values unchanged;
//   - States and batches go on into a real runtime::AgentRuntime (the code both runtimes share): a State is
//     either not well-formed (and rejected), or rejected by the runtime with a reason, or accepted, and
//     an accepted State is finite, symmetric PSD and within the absurd-magnitude bounds; after every
//     estimator step the agent's estimate is finite.
//   - Half the States are 3-D (an altitude and one peer z per edge summary; a third of the sessions run
//     dml in 3-D, which reads them): their z parts get the same value and sequence mutations, plus peer
//     z's that disagree with the edge summaries and _maximum / _release changes, which the decoder must
//     ignore. A well-formed 3-D State carries its z part bit for bit; one refused for its z part alone is
//     refused with the reason of the runtime's first failed z check.
//   - States carry dml's cavities (one offset z each in 3-D): they get hostile values, other lengths and
//     offset z's that disagree with them; a well-formed State carries them bit for bit, and one refused for
//     its cavities alone is refused with the reason of the runtime's first failed cavity check.
// Scenario parser: a valid YAML text (the default scenario, to_yaml of varied scenarios, hand-written
// fragments) gets 1–6 text mutations (bit flips, random/structural bytes, deletions, truncation,
// duplicated/swapped lines, inserted keys, values replaced by huge numbers, special floats, YAML tags and
// anchors), sometimes plus `--set` overrides. Contract: parse_scenario either throws config::ScenarioError
// or returns a scenario that validate() accepts and that round-trips exactly through to_yaml().
#include "fuzz_targets.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <exception>
#include <fstream>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <string_view>
#include <typeinfo>

#include "convert.hpp"
#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/core/gaussian.hpp"
#include "swarmloc/core/random.hpp"
#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/runtime/agent_runtime.hpp"

namespace swarmloc::fuzz {
namespace {

constexpr std::size_t kMaxFailuresKept = 5;

/// Counter-based generator: input i of a target is reproducible on its own.
class Rng {
 public:
  explicit Rng(std::uint64_t state) : state_(state) {}
  std::uint64_t next() { return core::mix64(state_++ ^ 0xa0761d6478bd642fULL); }
  /// Uniform in [0, n); n > 0.
  std::uint64_t below(std::uint64_t n) { return next() % n; }
  bool chance(double p) { return core::unit_uniform(next()) < p; }
  double uniform(double low, double high) { return low + (high - low) * core::unit_uniform(next()); }

 private:
  std::uint64_t state_;
};

double hostile_double(Rng& rng) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  switch (rng.below(14)) {
    case 0:
      return std::numeric_limits<double>::quiet_NaN();
    case 1:
      return kInf;
    case 2:
      return -kInf;
    case 3:
      return std::numeric_limits<double>::max();
    case 4:
      return -std::numeric_limits<double>::max();
    case 5:
      return std::numeric_limits<double>::denorm_min();
    case 6:
      return -0.0;
    case 7:
      return 0.0;
    case 8:
      return rng.chance(0.5) ? 1e300 : -1e300;
    case 9:
      return std::bit_cast<double>(rng.next());  // any bit pattern, signalling NaNs included
    case 10:
      return rng.uniform(-1e7, 1e7);  // around the absurd-magnitude bound (1e6)
    case 11:
      return rng.chance(0.5) ? 1e14 : 1e15;  // around the absurd-variance bound
    case 12:
      return -rng.uniform(0.0, 10.0);  // negative variances / ranges
    default:
      return rng.uniform(-100.0, 100.0);
  }
}

template <typename I>
I hostile_int(Rng& rng) {
  switch (rng.below(6)) {
    case 0:
      return std::numeric_limits<I>::min();
    case 1:
      return std::numeric_limits<I>::max();
    case 2:
      return static_cast<I>(0);
    case 3:
      return static_cast<I>(-1);  // wraps for unsigned types
    case 4:
      return static_cast<I>(rng.below(8));
    default:
      return static_cast<I>(rng.next());
  }
}

/// Random bytes over a trivially copyable struct (pointers and bools are fixed up by the caller).
template <typename T>
void random_bytes(T& value, Rng& rng) {
  static_assert(std::is_trivially_copyable_v<T>);
  std::array<unsigned char, sizeof(T)> bytes{};
  for (auto& byte : bytes) byte = static_cast<unsigned char>(rng.next());
  std::memcpy(&value, bytes.data(), sizeof(T));
}

bool same_bits(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}

Mat2 random_psd(Rng& rng, double scale) {
  Mat2 a;
  a << rng.uniform(-scale, scale), rng.uniform(-scale, scale), rng.uniform(-scale, scale),
      rng.uniform(-scale, scale);
  return core::symmetrized(a * a.transpose() + 1e-6 * Mat2::Identity());
}

/// Gives a sequence a new length and contents in `storage` (or a null buffer with a non-zero length).
template <typename Sequence, typename Element, typename Fill>
void reshape(Sequence& sequence, std::vector<Element>& storage, std::size_t bound, Rng& rng, Fill fill) {
  std::size_t length = 0;
  switch (rng.below(7)) {
    case 0:
      length = 0;
      break;
    case 1:
      length = 1 + rng.below(4);
      break;
    case 2:
      length = bound == 0 ? 0 : bound - 1 + rng.below(3);  // bound − 1, bound, bound + 1
      break;
    case 3:
      length = rng.chance(0.01) ? 20000 + rng.below(20000) : rng.below(2 * bound + 3);
      break;
    default:
      length = rng.below(bound + 2);
  }
  storage.resize(length);
  for (auto& element : storage) fill(element);
  sequence._length = static_cast<std::uint32_t>(length);
  sequence._maximum = rng.chance(0.8) ? sequence._length : static_cast<std::uint32_t>(rng.next());
  sequence._buffer = storage.empty() ? nullptr : storage.data();
  sequence._release = false;
  if (rng.chance(0.05)) {
    sequence._length = static_cast<std::uint32_t>(1 + rng.below(100));
    sequence._buffer = nullptr;  // claims elements, has none
  }
}

void mutate_header(swarmloc_msg_Header& header, Rng& rng) {
  switch (rng.below(5)) {
    case 0:
      header.agent_id = hostile_int<std::int32_t>(rng);
      break;
    case 1:
      header.seq = hostile_int<std::uint32_t>(rng);
      break;
    case 2:
      header.step = hostile_int<std::int64_t>(rng);
      break;
    case 3:
      header.sender_stamp_ns = hostile_int<std::int64_t>(rng);
      break;
    default:
      header.world_stamp_ns = hostile_int<std::int64_t>(rng);
  }
}

runtime::Header random_header(Rng& rng, AgentId sender, std::uint32_t seq) {
  runtime::Header header;
  header.agent_id = sender;
  header.seq = seq;
  header.step = static_cast<std::int64_t>(seq);
  header.sender_stamp_ns = static_cast<std::int64_t>(rng.below(1000000000));
  header.world_stamp_ns = static_cast<std::int64_t>(seq) * 100000000;
  return header;
}

class Recorder {
 public:
  explicit Recorder(FuzzResult& result) : result_(result) {}
  void violation(std::uint64_t input, const std::string& what) {
    ++result_.violations;
    if (result_.failures.size() < kMaxFailuresKept)
      result_.failures.push_back("input " + std::to_string(input) + ": " + what);
  }
  void check(bool condition, std::uint64_t input, const char* what) {
    if (!condition) violation(input, what);
  }

 private:
  FuzzResult& result_;
};

// ---------------------------------------------------------------------------------------------------
// The agent under test for States and batches: agent 0 with neighbours 1, 2, 3, running the IEIF or the
// IEKF in a planar world, or (State sessions) dml in a 3-D one, which reads the accepted z parts.

constexpr AgentId kSelf = 0;
const std::vector<AgentId> kNeighbours{1, 2, 3};

runtime::AgentRuntime make_runtime(std::uint64_t seed, const std::string& algorithm, int dimensions = 2) {
  estimators::AgentSetup setup;
  setup.id = kSelf;
  setup.initial_guess_m = Vec2(5.0, 5.0);
  setup.dimensions = dimensions;
  const estimators::EstimatorParams params;
  runtime::AgentRuntimeParams runtime;
  runtime.seed = seed;
  return runtime::AgentRuntime(config::make_estimator(algorithm, setup, params), setup, kNeighbours, runtime);
}

estimators::MeasurementBatch plausible_batch(Rng& rng, std::int64_t step) {
  estimators::MeasurementBatch batch;
  batch.world_step = step;
  batch.world_time_s = 0.1 * static_cast<double>(step);
  for (const AgentId peer : kNeighbours) batch.ranges.push_back({peer, rng.uniform(1.0, 15.0), 0.1});
  batch.neighbours = kNeighbours;
  return batch;
}

bool estimate_is_finite(const runtime::AgentRuntime& runtime) {
  const auto estimate = runtime.estimate();
  const auto& z = estimate.altitude;
  return estimate.mean_m.allFinite() && estimate.covariance.allFinite() &&
         (!z || (std::isfinite(z->z_m) && std::isfinite(z->variance_m2) && z->cross_m2.allFinite()));
}

// ---------------------------------------------------------------------------------------------------
// State

/// A 3-D sender's z part: a random (x, y, z) covariance split into its planar block and its z row, so the
/// joined covariance is PSD by construction (an anchor's stays zero), and every edge gets its peer's z.
void add_random_altitude(estimators::StateMessage& state, Rng& rng) {
  Mat3 factor;
  for (Eigen::Index k = 0; k < factor.size(); ++k) factor(k) = rng.uniform(-2.0, 2.0);
  Mat3 covariance = Mat3::Zero();
  if (!state.anchor) {
    covariance = factor * factor.transpose() + 1e-6 * Mat3::Identity();
    covariance = (0.5 * (covariance + covariance.transpose())).eval();
  }
  state.covariance = covariance.topLeftCorner<2, 2>();
  state.altitude = Altitude{rng.uniform(-30.0, 30.0), covariance(2, 2), covariance.topRightCorner<2, 1>()};
  for (auto& edge : state.edge_ranges) edge.peer_z_m = rng.uniform(-30.0, 30.0);
  for (auto& cavity : state.cavities) cavity.offset_z_m = rng.uniform(-5.0, 5.0);
}

estimators::StateMessage random_state(Rng& rng) {
  estimators::StateMessage state;
  state.anchor = rng.chance(0.3);
  state.active = rng.chance(0.9);
  state.inconsistent = rng.chance(0.1);
  state.mean_m = Vec2(rng.uniform(-50.0, 50.0), rng.uniform(-50.0, 50.0));
  state.covariance = state.anchor ? Mat2::Zero() : random_psd(rng, 2.0);
  state.degree = static_cast<std::uint16_t>(rng.below(20));
  for (std::uint64_t k = rng.below(4); k > 0; --k) {  // dml's edge summaries
    state.edge_ranges.push_back({static_cast<AgentId>(rng.below(8)), rng.uniform(0.0, 1e4),
                                 rng.uniform(0.0, 30.0),
                                 Vec2(rng.uniform(-50.0, 50.0), rng.uniform(-50.0, 50.0))});
  }
  for (std::uint64_t k = rng.below(4); k > 0; --k) {  // dml's cavities
    state.cavities.push_back({static_cast<AgentId>(rng.below(8)),
                              Vec2(rng.uniform(-5.0, 5.0), rng.uniform(-5.0, 5.0)), 0.0,
                              rng.uniform(0.0, 10.0)});
  }
  if (rng.chance(0.5)) add_random_altitude(state, rng);
  return state;
}

template <typename Sequence>
bool has_buffer_for_length(const Sequence& sequence) {
  return sequence._length == 0 || sequence._buffer != nullptr;
}

/// The decoder's structural rule for a State (dds::decode): known flags, key = sender, a buffer behind every
/// sequence's length, at most 16 edge summaries, 64 cavities and one altitude, one peer z per edge and one
/// offset z per cavity in a 3-D sample and none in a planar one, every edge finite with information >= 0
/// (its peer z included) and every cavity finite with variance >= 0 (its offset z included). Elements are
/// read only once the lengths are known to be backed by a buffer.
bool state_well_formed_by_rule(const swarmloc_msg_State& s) {
  if ((s.flags & ~dds::codec::kStateFlagsKnown) != 0 || s.agent_id != s.header.agent_id) return false;
  if (!has_buffer_for_length(s.edge_ranges) || !has_buffer_for_length(s.altitude) ||
      !has_buffer_for_length(s.edge_peer_z) || !has_buffer_for_length(s.cavities) ||
      !has_buffer_for_length(s.cavity_offset_z)) {
    return false;
  }
  const bool spatial = s.altitude._length == 1;
  if (s.edge_ranges._length > dds::codec::kMaxEdgeRanges || s.altitude._length > 1 ||
      s.edge_peer_z._length != (spatial ? s.edge_ranges._length : 0) ||
      s.cavities._length > dds::codec::kMaxCavities ||
      s.cavity_offset_z._length != (spatial ? s.cavities._length : 0)) {
    return false;
  }
  for (std::uint32_t k = 0; k < s.cavities._length; ++k) {
    const auto& cavity = s.cavities._buffer[k];
    if (!std::isfinite(cavity.offset_m[0]) || !std::isfinite(cavity.offset_m[1]) ||
        !std::isfinite(cavity.variance_m2) || !(cavity.variance_m2 >= 0.0) ||
        (spatial && !std::isfinite(s.cavity_offset_z._buffer[k]))) {
      return false;
    }
  }
  for (std::uint32_t k = 0; k < s.edge_ranges._length; ++k) {
    const auto& edge = s.edge_ranges._buffer[k];
    if (!std::isfinite(edge.information) || !(edge.information >= 0.0) || !std::isfinite(edge.mean_range_m) ||
        !std::isfinite(edge.peer_mean_m[0]) || !std::isfinite(edge.peer_mean_m[1]) ||
        (spatial && !std::isfinite(s.edge_peer_z._buffer[k]))) {
      return false;
    }
  }
  return true;
}

/// A well-formed State's z part as decoded equals the wire's bit for bit: the altitude exactly when the
/// wire has one, and every edge's peer z (+0 in a planar sample). Reads the wire only where its lengths
/// are backed: a sample wrongly called well-formed makes it return false, not read past a buffer.
bool state_z_part_as_on_wire(const estimators::StateMessage& decoded, const swarmloc_msg_State& s) {
  if (decoded.altitude.has_value() != (s.altitude._length == 1 && s.altitude._buffer != nullptr))
    return false;
  if (const auto& z = decoded.altitude) {
    const auto& wire = s.altitude._buffer[0];
    if (!same_bits(z->z_m, wire.z_m) || !same_bits(z->variance_m2, wire.variance_m2) ||
        !same_bits(z->cross_m2.x(), wire.cross_m2[0]) || !same_bits(z->cross_m2.y(), wire.cross_m2[1])) {
      return false;
    }
  }
  const std::size_t edges = decoded.edge_ranges.size();
  const bool peer_z_backed =
      edges == 0 || (s.edge_peer_z._length == edges && s.edge_peer_z._buffer != nullptr);
  if (edges != s.edge_ranges._length || (decoded.altitude && !peer_z_backed)) return false;
  for (std::size_t k = 0; k < edges; ++k) {
    const double wire_z = decoded.altitude ? s.edge_peer_z._buffer[k] : 0.0;
    if (!same_bits(decoded.edge_ranges[k].peer_z_m, wire_z)) return false;
  }
  return true;
}

/// A well-formed State's cavities as decoded equal the wire's bit for bit: peer, offset, variance, and the
/// offset z (+0 in a planar sample). Reads the wire only where its lengths are backed.
bool state_cavities_as_on_wire(const estimators::StateMessage& decoded, const swarmloc_msg_State& s) {
  const std::size_t cavities = decoded.cavities.size();
  if (cavities != s.cavities._length || (cavities > 0 && s.cavities._buffer == nullptr)) return false;
  const bool offset_z_backed =
      cavities == 0 || (s.cavity_offset_z._length == cavities && s.cavity_offset_z._buffer != nullptr);
  if (decoded.altitude && !offset_z_backed) return false;
  for (std::size_t k = 0; k < cavities; ++k) {
    const auto& got = decoded.cavities[k];
    const auto& wire = s.cavities._buffer[k];
    const double wire_z = decoded.altitude ? s.cavity_offset_z._buffer[k] : 0.0;
    if (got.peer != wire.peer || !same_bits(got.offset_m.x(), wire.offset_m[0]) ||
        !same_bits(got.offset_m.y(), wire.offset_m[1]) || !same_bits(got.offset_z_m, wire_z) ||
        !same_bits(got.variance_m2, wire.variance_m2)) {
      return false;
    }
  }
  return true;
}

// The runtime's bounds (runtime::AgentRuntimeParams' defaults, which make_runtime keeps).
constexpr double kFuzzPositionBoundM = 1e6;
constexpr double kFuzzVarianceBoundM2 = 1e14;

/// A State's planar part passes the runtime's checks: finite, within the absurd bounds, symmetric PSD;
/// every edge summary's and every cavity's planar numbers finite and within them.
bool state_planar_part_plausible(const estimators::StateMessage& m) {
  if (!m.mean_m.allFinite() || !m.covariance.allFinite() || m.mean_m.norm() > kFuzzPositionBoundM ||
      m.covariance.cwiseAbs().maxCoeff() > kFuzzVarianceBoundM2 ||
      !core::is_symmetric_psd(m.covariance, 1e-9)) {
    return false;
  }
  const bool edges_plausible = std::all_of(m.edge_ranges.begin(), m.edge_ranges.end(), [](const auto& edge) {
    return std::isfinite(edge.information) && edge.information >= 0.0 && edge.information <= 1e30 &&
           std::isfinite(edge.mean_range_m) && edge.mean_range_m >= 0.0 &&
           edge.mean_range_m <= 2.0 * kFuzzPositionBoundM && edge.peer_mean_m.allFinite() &&
           edge.peer_mean_m.norm() <= kFuzzPositionBoundM;
  });
  return edges_plausible && m.cavities.size() <= estimators::StateMessage::kMaxCavities &&
         std::all_of(m.cavities.begin(), m.cavities.end(), [](const auto& cavity) {
           return cavity.offset_m.allFinite() && cavity.offset_m.norm() <= kFuzzPositionBoundM &&
                  std::isfinite(cavity.variance_m2) && cavity.variance_m2 >= 0.0 &&
                  cavity.variance_m2 <= kFuzzVarianceBoundM2;
         });
}

/// Why the runtime must refuse a State for its cavities (its checks in their order: too many; then each
/// cavity non-finite, or its variance negative or absurd, or its offset (with z) beyond the position bound);
/// nullopt if they are plausible.
std::optional<runtime::RejectReason> state_cavity_fault(const estimators::StateMessage& m) {
  using runtime::RejectReason;
  if (m.cavities.size() > estimators::StateMessage::kMaxCavities) return RejectReason::kAbsurdMagnitude;
  for (const auto& cavity : m.cavities) {
    if (!cavity.offset_m.allFinite() || !std::isfinite(cavity.offset_z_m) ||
        !std::isfinite(cavity.variance_m2))
      return RejectReason::kNonFinite;
    if (cavity.variance_m2 < 0.0 || cavity.variance_m2 > kFuzzVarianceBoundM2 ||
        join(cavity.offset_m, cavity.offset_z_m).norm() > kFuzzPositionBoundM) {
      return RejectReason::kAbsurdMagnitude;
    }
  }
  return std::nullopt;
}

/// Why the runtime must refuse a State whose planar part is plausible, for its z part alone (its checks in
/// their order: the altitude non-finite, beyond the bounds, not PSD; then each edge's peer (x, y, z); then
/// each cavity's offset (x, y, z)); nullopt if the z part is plausible.
std::optional<runtime::RejectReason> state_z_part_fault(const estimators::StateMessage& m) {
  using runtime::RejectReason;
  if (const auto& z = m.altitude) {
    if (!std::isfinite(z->z_m) || !std::isfinite(z->variance_m2) || !z->cross_m2.allFinite())
      return RejectReason::kNonFinite;
    if (join(m.mean_m, z->z_m).norm() > kFuzzPositionBoundM ||
        std::abs(z->variance_m2) > kFuzzVarianceBoundM2 ||
        z->cross_m2.cwiseAbs().maxCoeff() > kFuzzVarianceBoundM2) {
      return RejectReason::kAbsurdMagnitude;
    }
    if (z->variance_m2 < 0.0 || !core::is_symmetric_psd_dynamic(MatX(join(m.covariance, *z)), 1e-9))
      return RejectReason::kNotSymmetricPsd;
  }
  for (const auto& edge : m.edge_ranges) {
    if (!std::isfinite(edge.peer_z_m)) return RejectReason::kNonFinite;
    if (join(edge.peer_mean_m, edge.peer_z_m).norm() > kFuzzPositionBoundM)
      return RejectReason::kAbsurdMagnitude;
  }
  for (const auto& cavity : m.cavities) {
    if (!std::isfinite(cavity.offset_z_m)) return RejectReason::kNonFinite;
    if (join(cavity.offset_m, cavity.offset_z_m).norm() > kFuzzPositionBoundM)
      return RejectReason::kAbsurdMagnitude;
  }
  return std::nullopt;
}

/// What a mutated State's sequences point into once a mutation gives one a new length (until then, into
/// the WireState's own vectors).
struct StateSequenceStorage {
  std::vector<swarmloc_msg_EdgeRange> edge_ranges;
  std::vector<swarmloc_msg_Altitude> altitude;
  std::vector<double> edge_peer_z;
  std::vector<swarmloc_msg_EdgeCavity> cavities;
  std::vector<double> cavity_offset_z;
};

/// Points a State sequence at `storage`, as the writer does (_maximum = _length, not released).
template <typename Sequence, typename Element>
void point_state_sequence_at(Sequence& sequence, std::vector<Element>& storage) {
  sequence._length = static_cast<std::uint32_t>(storage.size());
  sequence._maximum = sequence._length;
  sequence._buffer = storage.empty() ? nullptr : storage.data();
  sequence._release = false;
}

/// One of the State's five sequences, at random.
template <typename Visit>
void visit_random_state_sequence(swarmloc_msg_State& s, Rng& rng, Visit visit) {
  switch (rng.below(5)) {
    case 0:
      visit(s.edge_ranges);
      break;
    case 1:
      visit(s.altitude);
      break;
    case 2:
      visit(s.edge_peer_z);
      break;
    case 3:
      visit(s.cavities);
      break;
    default:
      visit(s.cavity_offset_z);
  }
}

void fill_edge_range(swarmloc_msg_EdgeRange& edge, Rng& rng) {
  edge.peer = static_cast<std::int32_t>(rng.below(8));
  edge.information = rng.chance(0.8) ? rng.uniform(0.0, 1e4) : hostile_double(rng);
  edge.mean_range_m = rng.chance(0.8) ? rng.uniform(0.0, 30.0) : hostile_double(rng);
  for (auto& v : edge.peer_mean_m) v = rng.chance(0.9) ? rng.uniform(-50.0, 50.0) : hostile_double(rng);
}

/// Mostly a usable z part (var(z) > 0 and no correlation is PSD beside any PSD planar block).
void fill_altitude(swarmloc_msg_Altitude& altitude, Rng& rng) {
  altitude.z_m = rng.chance(0.8) ? rng.uniform(-30.0, 30.0) : hostile_double(rng);
  altitude.variance_m2 = rng.chance(0.8) ? rng.uniform(0.01, 4.0) : hostile_double(rng);
  for (auto& v : altitude.cross_m2) v = rng.chance(0.8) ? 0.0 : hostile_double(rng);
}

void fill_peer_z(double& z, Rng& rng) {
  z = rng.chance(0.8) ? rng.uniform(-30.0, 30.0) : hostile_double(rng);
}

/// Mostly a plausible cavity; always one if `plausible`.
void fill_cavity(swarmloc_msg_EdgeCavity& cavity, Rng& rng, bool plausible) {
  cavity.peer = static_cast<std::int32_t>(rng.below(8));
  for (auto& v : cavity.offset_m)
    v = plausible || rng.chance(0.9) ? rng.uniform(-5.0, 5.0) : hostile_double(rng);
  cavity.variance_m2 = plausible || rng.chance(0.8) ? rng.uniform(0.0, 10.0) : hostile_double(rng);
}

void fill_offset_z(double& z, Rng& rng) {
  z = rng.chance(0.8) ? rng.uniform(-5.0, 5.0) : hostile_double(rng);
}

// random_bytes below leaves the sample well-defined only because it restores every sequence member: a
// member added to State after cavity_offset_z must be restored there too.
static_assert(offsetof(swarmloc_msg_State, cavity_offset_z) + sizeof(swarmloc_msg_State::cavity_offset_z) ==
              sizeof(swarmloc_msg_State));

/// Every mutation keeps the invariant the decoder relies on: a non-null _buffer holds _length elements.
void mutate(swarmloc_msg_State& s, StateSequenceStorage& storage, Rng& rng) {
  switch (rng.below(22)) {
    case 0:
      s.agent_id = hostile_int<std::int32_t>(rng);
      break;
    case 1:
      mutate_header(s.header, rng);
      break;
    case 2:
      s.mean_m[rng.below(2)] = hostile_double(rng);
      break;
    case 3:
      s.covariance[rng.below(3)] = hostile_double(rng);
      break;
    case 4:
      s.flags = hostile_int<std::uint8_t>(rng);
      break;
    case 5:
      s.degree = hostile_int<std::uint16_t>(rng);
      break;
    case 6:
      s.covariance[1] = rng.uniform(-10.0, 10.0);  // plausible numbers, not PSD
      break;
    case 7:
      if (s.edge_ranges._length > 0 && s.edge_ranges._buffer != nullptr) {
        auto& edge = s.edge_ranges._buffer[rng.below(s.edge_ranges._length)];
        (rng.chance(0.5) ? edge.information : edge.mean_range_m) = hostile_double(rng);
      }
      break;
    case 8:
      if (s.altitude._length > 0 && s.altitude._buffer != nullptr) {
        auto& z = s.altitude._buffer[rng.below(s.altitude._length)];
        switch (rng.below(3)) {
          case 0:
            z.z_m = hostile_double(rng);
            break;
          case 1:
            z.variance_m2 = hostile_double(rng);
            break;
          default:
            z.cross_m2[rng.below(2)] = hostile_double(rng);
        }
      }
      break;
    case 9:
      if (s.edge_peer_z._length > 0 && s.edge_peer_z._buffer != nullptr)
        s.edge_peer_z._buffer[rng.below(s.edge_peer_z._length)] = hostile_double(rng);
      break;
    case 10:
      reshape(s.altitude, storage.altitude, 1, rng, [&](swarmloc_msg_Altitude& z) { fill_altitude(z, rng); });
      break;
    case 11:
      reshape(s.edge_peer_z, storage.edge_peer_z, dds::codec::kMaxEdgeRanges, rng,
              [&](double& z) { fill_peer_z(z, rng); });
      break;
    case 12: {
      // Peer z's that disagree with the planar part: one too few or too many for the edges, or some in a
      // sample without an altitude.
      // (An absurd edge count, which case 15 may have set without a buffer, is malformed anyway.)
      const std::size_t edges = std::min<std::size_t>(s.edge_ranges._length, dds::codec::kMaxEdgeRanges + 1);
      std::size_t length = rng.chance(0.5) ? edges + 1 : (edges > 0 ? edges - 1 : 2);
      if (rng.chance(0.3)) {
        storage.altitude.clear();
        point_state_sequence_at(s.altitude, storage.altitude);
        length = std::max<std::size_t>(edges, 1);
      }
      storage.edge_peer_z.resize(length);
      for (auto& z : storage.edge_peer_z) fill_peer_z(z, rng);
      point_state_sequence_at(s.edge_peer_z, storage.edge_peer_z);
      break;
    }
    case 13:
      reshape(s.edge_ranges, storage.edge_ranges, dds::codec::kMaxEdgeRanges, rng,
              [&](swarmloc_msg_EdgeRange& edge) { fill_edge_range(edge, rng); });
      break;
    case 14:
      // The decoder reads _length elements and frees nothing: _maximum below or far above _length and a
      // set _release change nothing.
      visit_random_state_sequence(s, rng, [&](auto& sequence) {
        sequence._maximum = rng.chance(0.5) && sequence._length > 0
                                ? static_cast<std::uint32_t>(rng.below(sequence._length))
                                : hostile_int<std::uint32_t>(rng);
        sequence._release = rng.chance(0.5);
      });
      break;
    case 15:
      // A length without a buffer, up to an absurd one.
      visit_random_state_sequence(s, rng, [&](auto& sequence) {
        sequence._length = rng.chance(0.5) ? static_cast<std::uint32_t>(1 + rng.below(100))
                                           : std::max<std::uint32_t>(1, hostile_int<std::uint32_t>(rng));
        sequence._buffer = nullptr;
      });
      break;
    case 16:
      if (s.cavities._length > 0 && s.cavities._buffer != nullptr) {
        auto& cavity = s.cavities._buffer[rng.below(s.cavities._length)];
        (rng.chance(0.6) ? cavity.variance_m2 : cavity.offset_m[rng.below(2)]) = hostile_double(rng);
      }
      break;
    case 17:
      if (s.cavity_offset_z._length > 0 && s.cavity_offset_z._buffer != nullptr)
        s.cavity_offset_z._buffer[rng.below(s.cavity_offset_z._length)] = hostile_double(rng);
      break;
    case 18: {
      // Half the time every cavity is plausible: a long sequence of them is then malformed only by its
      // length.
      const bool plausible = rng.chance(0.5);
      reshape(s.cavities, storage.cavities, dds::codec::kMaxCavities, rng,
              [&](swarmloc_msg_EdgeCavity& cavity) { fill_cavity(cavity, rng, plausible); });
      break;
    }
    case 19:
      reshape(s.cavity_offset_z, storage.cavity_offset_z, dds::codec::kMaxCavities, rng,
              [&](double& z) { fill_offset_z(z, rng); });
      break;
    case 20: {
      // Offset z's that disagree with the cavities: one too few or too many, or some in a sample without an
      // altitude (an absurd cavity count without a buffer is malformed anyway).
      const std::size_t cavities = std::min<std::size_t>(s.cavities._length, dds::codec::kMaxCavities + 1);
      std::size_t length = rng.chance(0.5) ? cavities + 1 : (cavities > 0 ? cavities - 1 : 2);
      if (rng.chance(0.3)) {
        storage.altitude.clear();
        point_state_sequence_at(s.altitude, storage.altitude);
        length = std::max<std::size_t>(cavities, 1);
      }
      storage.cavity_offset_z.resize(length);
      for (auto& z : storage.cavity_offset_z) fill_offset_z(z, rng);
      point_state_sequence_at(s.cavity_offset_z, storage.cavity_offset_z);
      break;
    }
    default: {
      // Random bytes over everything but the sequences: a CDR reader never hands over a wild pointer.
      const auto edge_ranges = s.edge_ranges;
      const auto altitude = s.altitude;
      const auto edge_peer_z = s.edge_peer_z;
      const auto cavities = s.cavities;
      const auto cavity_offset_z = s.cavity_offset_z;
      random_bytes(s, rng);
      s.edge_ranges = edge_ranges;
      s.altitude = altitude;
      s.edge_peer_z = edge_peer_z;
      s.cavities = cavities;
      s.cavity_offset_z = cavity_offset_z;
    }
  }
}

/// Sessions of kSession inputs share one runtime, so duplicate / reordered / mailbox paths are reached.
constexpr std::uint64_t kSession = 64;

void fuzz_state(std::uint64_t seed, std::uint64_t first, std::uint64_t inputs, FuzzResult& result) {
  Recorder record(result);
  std::unique_ptr<runtime::AgentRuntime> runtime;
  for (std::uint64_t i = first; i < first + inputs; ++i) {
    Rng rng(core::hash_keys(seed, 1, i));
    if (runtime == nullptr || i % kSession == 0 || i == first) {
      const auto pick = rng.below(3);
      runtime = std::make_unique<runtime::AgentRuntime>(
          pick == 2 ? make_runtime(seed, "dml", 3) : make_runtime(seed, pick == 0 ? "ieif" : "iekf"));
    }
    const AgentId sender = rng.chance(0.9) ? kNeighbours[rng.below(3)] : hostile_int<std::int32_t>(rng);
    dds::WireState wire(random_header(rng, sender, static_cast<std::uint32_t>(i % kSession)),
                        random_state(rng));
    swarmloc_msg_State sample = wire.sample;
    StateSequenceStorage storage;
    const auto mutations = rng.below(6);
    for (std::uint64_t m = 0; m < mutations; ++m) mutate(sample, storage, rng);

    const auto decoded = dds::decode(sample);
    const bool expect_well_formed = state_well_formed_by_rule(sample);
    record.check(decoded.well_formed == expect_well_formed, i, "state: well_formed differs from the rule");
    const bool spatial = sample.altitude._length != 0 || sample.edge_peer_z._length != 0 ||
                         sample.cavity_offset_z._length != 0;
    if (!decoded.well_formed && spatial) {
      auto planar = sample;  // the same sample without its 3-D part: was the 3-D part what broke it?
      planar.altitude = {};
      planar.edge_peer_z = {};
      planar.cavity_offset_z = {};
      if (state_well_formed_by_rule(planar)) ++result.reached["3d malformed by its z part"];
    }
    if (!decoded.well_formed && (sample.cavities._length != 0 || sample.cavity_offset_z._length != 0)) {
      auto without = sample;  // the same sample without its cavities: were they what broke it?
      without.cavities = {};
      without.cavity_offset_z = {};
      if (state_well_formed_by_rule(without)) ++result.reached["malformed by its cavities"];
    }
    if (decoded.well_formed) {
      record.check(same_bits(decoded.message.mean_m.x(), sample.mean_m[0]) &&
                       same_bits(decoded.message.mean_m.y(), sample.mean_m[1]) &&
                       same_bits(decoded.message.covariance(0, 1), sample.covariance[1]) &&
                       same_bits(decoded.message.covariance(1, 0), sample.covariance[1]) &&
                       decoded.header.seq == sample.header.seq,
                   i, "state: decoded values differ from the wire");
      record.check(state_z_part_as_on_wire(decoded.message, sample), i,
                   "state: decoded z part differs from the wire");
      record.check(state_cavities_as_on_wire(decoded.message, sample), i,
                   "state: decoded cavities differ from the wire");
    }
    const auto before = runtime->rejected_by_reason();
    const bool accepted = runtime->on_state(decoded.header, decoded.message, decoded.well_formed);
    const auto after = runtime->rejected_by_reason();
    if (!decoded.well_formed) {
      record.check(!accepted, i, "state: a malformed sample was accepted");
      if (decoded.header.agent_id != kSelf) {
        record.check(after[static_cast<std::size_t>(runtime::RejectReason::kMalformed)] ==
                         before[static_cast<std::size_t>(runtime::RejectReason::kMalformed)] + 1,
                     i, "state: a malformed sample was not counted as malformed");
      }
    }
    const auto& m = decoded.message;
    if (accepted) {
      ++result.accepted;
      record.check(m.mean_m.allFinite() && m.covariance.allFinite(), i,
                   "state: accepted a non-finite sample");
      record.check(core::is_symmetric_psd(m.covariance, 1e-9), i, "state: accepted a non-PSD covariance");
      record.check(m.mean_m.norm() <= 1e6 && m.covariance.cwiseAbs().maxCoeff() <= 1e14, i,
                   "state: accepted an absurd magnitude");
      record.check(!state_z_part_fault(m), i, "state: accepted an implausible z part");
      record.check(!state_cavity_fault(m), i, "state: accepted an implausible cavity");
      if (m.altitude) ++result.reached["3d accepted"];
      if (!m.cavities.empty()) ++result.reached[m.altitude ? "3d cavities accepted" : "cavities accepted"];
    } else {
      ++result.rejected;
      if (decoded.header.agent_id != kSelf) {
        std::uint64_t counted = 0;
        std::size_t reason = 0;
        for (std::size_t r = 0; r < after.size(); ++r) {
          counted += after[r] - before[r];
          if (after[r] != before[r]) reason = r;
        }
        record.check(counted == 1, i, "state: a rejection was not counted under exactly one reason");
        // A well-formed 3-D sample from a neighbour whose planar part is plausible: its z part alone decides,
        // with the reason of the first failed check.
        const auto z_fault = state_z_part_fault(m);
        if (decoded.well_formed && m.altitude && z_fault && state_planar_part_plausible(m) &&
            std::find(kNeighbours.begin(), kNeighbours.end(), decoded.header.agent_id) != kNeighbours.end()) {
          record.check(counted == 1 && reason == static_cast<std::size_t>(*z_fault), i,
                       "state: a z part was refused for another reason");
          ++result.reached[std::string("3d refused for its z part: ") + runtime::to_string(*z_fault)];
        }
        // A well-formed sample from a neighbour that would pass without its cavities: they alone decide.
        auto rest = m;
        rest.cavities.clear();
        const auto cavity_fault = state_cavity_fault(m);
        if (decoded.well_formed && cavity_fault && state_planar_part_plausible(rest) &&
            !state_z_part_fault(rest) &&
            std::find(kNeighbours.begin(), kNeighbours.end(), decoded.header.agent_id) != kNeighbours.end()) {
          record.check(counted == 1 && reason == static_cast<std::size_t>(*cavity_fault), i,
                       "state: cavities were refused for another reason");
          ++result.reached[std::string("refused for its cavities: ") + runtime::to_string(*cavity_fault)];
        }
      }
    }
    if (i % 4 == 3) {
      runtime->on_batch(decoded.header, plausible_batch(rng, static_cast<std::int64_t>(i)));
      (void)runtime->step(static_cast<std::int64_t>(i));
      record.check(estimate_is_finite(*runtime), i, "state: the estimate became non-finite");
    }
  }
}

/// A State sample that owns what its sequences point at, so a case can give any of them any length.
struct OwnedStateSample {
  explicit OwnedStateSample(const dds::WireState& wire)
      : edge_ranges(wire.edge_ranges),
        altitude(wire.altitude),
        edge_peer_z(wire.edge_peer_z),
        cavities(wire.cavities),
        cavity_offset_z(wire.cavity_offset_z),
        sample(wire.sample) {
    repoint();
  }
  OwnedStateSample(const OwnedStateSample&) = delete;
  OwnedStateSample& operator=(const OwnedStateSample&) = delete;
  /// Re-points the sample after a case resized a vector; each buffer then holds exactly its length, so
  /// AddressSanitizer sees a read past _length.
  void repoint() {
    edge_ranges.shrink_to_fit();
    altitude.shrink_to_fit();
    edge_peer_z.shrink_to_fit();
    cavities.shrink_to_fit();
    cavity_offset_z.shrink_to_fit();
    point_state_sequence_at(sample.edge_ranges, edge_ranges);
    point_state_sequence_at(sample.altitude, altitude);
    point_state_sequence_at(sample.edge_peer_z, edge_peer_z);
    point_state_sequence_at(sample.cavities, cavities);
    point_state_sequence_at(sample.cavity_offset_z, cavity_offset_z);
  }
  std::vector<swarmloc_msg_EdgeRange> edge_ranges;
  std::vector<swarmloc_msg_Altitude> altitude;
  std::vector<double> edge_peer_z;
  std::vector<swarmloc_msg_EdgeCavity> cavities;
  std::vector<double> cavity_offset_z;
  swarmloc_msg_State sample{};
};

/// A plausible 3-D State with two edge summaries and two cavities (doubles without short decimal forms, to
/// see any rounding).
estimators::StateMessage spatial_case_state() {
  estimators::StateMessage state;
  state.mean_m = Vec2(3.0, -4.0);
  state.covariance << 0.5, 0.1, 0.1, 0.6;
  state.degree = 2;
  state.edge_ranges = {{2, 1e4 / 3.0, 12.25, Vec2(0.1 + 0.2, -1.0 / 7.0), 2.0 / 7.0},
                       {3, 0.5, 7.5, Vec2(-4.0, 2.0 / 3.0), -1e-300}};
  // The (x, y, z) covariance is diagonally dominant, hence positive definite.
  state.altitude = Altitude{1.0 / 3.0, 0.7, Vec2(-0.1, 1.0 / 9.0)};
  state.cavities = {{2, Vec2(1.0 / 3.0, -0.1 - 0.2), 3.0 / 7.0, 2.0 / 9.0},
                    {3, Vec2(-2.5, 1e-300), -1.0 / 11.0, 0.0}};
  return state;
}

struct SpatialStateSpoiler {
  const char* name;
  void (*spoil)(OwnedStateSample&);
};

constexpr double kCaseNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kCaseInf = std::numeric_limits<double>::infinity();
constexpr std::uint32_t kCaseAbsurdLength = std::numeric_limits<std::uint32_t>::max();

const SpatialStateSpoiler kSpatialStateSpoilers[] = {
    {"valid", [](OwnedStateSample&) {}},
    {"valid without edge summaries",
     [](OwnedStateSample& o) {
       o.edge_ranges.clear();
       o.edge_peer_z.clear();
       o.repoint();
     }},
    {"planar",
     [](OwnedStateSample& o) {
       o.altitude.clear();
       o.edge_peer_z.clear();
       o.cavity_offset_z.clear();
       o.repoint();
     }},
    {"-0 z and a denormal peer z",
     [](OwnedStateSample& o) {
       o.altitude[0].z_m = -0.0;
       o.edge_peer_z[1] = std::numeric_limits<double>::denorm_min();
     }},
    {"lengths above _maximum, released",
     [](OwnedStateSample& o) {
       o.sample.altitude._maximum = 0;
       o.sample.edge_peer_z._maximum = 1;
       o.sample.altitude._release = true;  // nothing here frees the sample
       o.sample.edge_peer_z._release = true;
     }},
    {"_maximum far above the lengths",
     [](OwnedStateSample& o) {
       o.sample.altitude._maximum = kCaseAbsurdLength;
       o.sample.edge_peer_z._maximum = kCaseAbsurdLength;
     }},
    {"two altitudes",
     [](OwnedStateSample& o) {
       o.altitude.push_back(o.altitude[0]);
       o.repoint();
     }},
    {"altitude length without a buffer", [](OwnedStateSample& o) { o.sample.altitude._buffer = nullptr; }},
    {"absurd altitude length without a buffer",
     [](OwnedStateSample& o) {
       o.sample.altitude._length = kCaseAbsurdLength;
       o.sample.altitude._buffer = nullptr;
     }},
    {"one peer z too few",
     [](OwnedStateSample& o) {
       o.edge_peer_z.pop_back();
       o.repoint();
     }},
    {"one peer z too many",
     [](OwnedStateSample& o) {
       o.edge_peer_z.push_back(0.5);
       o.repoint();
     }},
    {"peer z's without an altitude",
     [](OwnedStateSample& o) {
       o.altitude.clear();
       o.repoint();
     }},
    {"an altitude without peer z's",
     [](OwnedStateSample& o) {
       o.edge_peer_z.clear();
       o.repoint();
     }},
    {"peer z length without a buffer", [](OwnedStateSample& o) { o.sample.edge_peer_z._buffer = nullptr; }},
    {"absurd peer z length without a buffer",
     [](OwnedStateSample& o) {
       o.sample.edge_peer_z._length = kCaseAbsurdLength;
       o.sample.edge_peer_z._buffer = nullptr;
     }},
    {"17 edge summaries and 17 peer z's",
     [](OwnedStateSample& o) {
       o.edge_ranges.resize(17, o.edge_ranges[0]);
       o.edge_peer_z.resize(17, 1.0);
       o.repoint();
     }},
    {"NaN peer z", [](OwnedStateSample& o) { o.edge_peer_z[0] = kCaseNan; }},
    {"-Inf peer z", [](OwnedStateSample& o) { o.edge_peer_z[1] = -kCaseInf; }},
    {"NaN z", [](OwnedStateSample& o) { o.altitude[0].z_m = kCaseNan; }},
    {"+Inf var(z)", [](OwnedStateSample& o) { o.altitude[0].variance_m2 = kCaseInf; }},
    {"NaN cov(y, z)", [](OwnedStateSample& o) { o.altitude[0].cross_m2[1] = -kCaseNan; }},
    {"z beyond the position bound", [](OwnedStateSample& o) { o.altitude[0].z_m = 2e6; }},
    {"var(z) beyond the variance bound", [](OwnedStateSample& o) { o.altitude[0].variance_m2 = 1e15; }},
    {"peer z beyond the position bound", [](OwnedStateSample& o) { o.edge_peer_z[1] = -2e6; }},
    {"negative var(z)",
     [](OwnedStateSample& o) {
       o.altitude[0].variance_m2 = -1e-12;  // below the PSD check's tolerance: only var(z) >= 0 refuses it
       o.altitude[0].cross_m2[0] = o.altitude[0].cross_m2[1] = 0.0;
     }},
    {"(x, z) correlation above 1", [](OwnedStateSample& o) { o.altitude[0].cross_m2[0] = 0.9; }},
    {"-0 cavity variance", [](OwnedStateSample& o) { o.cavities[0].variance_m2 = -0.0; }},
    {"one cavity z too few",
     [](OwnedStateSample& o) {
       o.cavity_offset_z.pop_back();
       o.repoint();
     }},
    {"an altitude without cavity z's",
     [](OwnedStateSample& o) {
       o.cavity_offset_z.clear();
       o.repoint();
     }},
    {"cavity length without a buffer", [](OwnedStateSample& o) { o.sample.cavities._buffer = nullptr; }},
    {"65 cavities and 65 cavity z's",
     [](OwnedStateSample& o) {
       o.cavities.resize(65, o.cavities[0]);
       o.cavity_offset_z.resize(65, 1.0);
       o.repoint();
     }},
    {"NaN cavity offset", [](OwnedStateSample& o) { o.cavities[1].offset_m[0] = kCaseNan; }},
    {"+Inf cavity z", [](OwnedStateSample& o) { o.cavity_offset_z[0] = kCaseInf; }},
    {"negative cavity variance", [](OwnedStateSample& o) { o.cavities[1].variance_m2 = -1e-300; }},
    {"cavity variance beyond the variance bound",
     [](OwnedStateSample& o) { o.cavities[0].variance_m2 = 1e15; }},
    {"cavity offset z beyond the position bound", [](OwnedStateSample& o) { o.cavity_offset_z[1] = 2e6; }},
};

}  // namespace

std::vector<SpatialStateCase> spatial_state_cases() {
  auto agent = make_runtime(1, "ieif");
  std::vector<SpatialStateCase> cases;
  std::uint32_t seq = 0;
  for (const auto& spoiler : kSpatialStateSpoilers) {
    ++seq;  // never a duplicate or a reordered sample
    runtime::Header header;
    header.agent_id = 1;
    header.seq = seq;
    header.step = seq;
    header.world_stamp_ns = static_cast<std::int64_t>(seq) * 100000000;
    const dds::WireState wire(header, spatial_case_state());
    OwnedStateSample owned(wire);
    spoiler.spoil(owned);
    const auto decoded = dds::decode(owned.sample);
    SpatialStateCase outcome;
    outcome.name = spoiler.name;
    outcome.well_formed = decoded.well_formed;
    outcome.z_intact = decoded.well_formed && state_z_part_as_on_wire(decoded.message, owned.sample) &&
                       state_cavities_as_on_wire(decoded.message, owned.sample);
    const auto before = agent.rejected_by_reason();
    outcome.accepted = agent.on_state(decoded.header, decoded.message, decoded.well_formed);
    const auto after = agent.rejected_by_reason();
    for (std::size_t r = 0; r < after.size(); ++r) {  // every count that moved, so a double count shows
      for (auto n = before[r]; n < after[r]; ++n) {
        if (!outcome.reason.empty()) outcome.reason += "+";
        outcome.reason += runtime::to_string(static_cast<runtime::RejectReason>(r));
      }
    }
    cases.push_back(outcome);
  }
  return cases;
}

namespace {

// ---------------------------------------------------------------------------------------------------
// Information

void fuzz_information(std::uint64_t seed, std::uint64_t first, std::uint64_t inputs, FuzzResult& result) {
  Recorder record(result);
  for (std::uint64_t i = first; i < first + inputs; ++i) {
    Rng rng(core::hash_keys(seed, 2, i));
    estimators::InformationMessage message;
    const auto n = static_cast<Eigen::Index>(rng.chance(0.05) ? rng.below(65) : rng.below(7));
    message.target = static_cast<std::int32_t>(rng.below(10));
    message.world_step = static_cast<std::int64_t>(rng.below(1000)) - 1;
    message.info_vec = VecX::Zero(n);
    message.info_mat = MatX::Identity(n, n);
    for (Eigen::Index r = 0; r < n; ++r) {
      message.info_vec(r) = rng.uniform(-10.0, 10.0);
      for (Eigen::Index c = r + 1; c < n; ++c)
        message.info_mat(r, c) = message.info_mat(c, r) = rng.uniform(-0.1, 0.1);
    }
    dds::WireInformation wire(random_header(rng, 1, static_cast<std::uint32_t>(i)), message);
    swarmloc_msg_Information& s = wire.sample;
    std::vector<double> vec_storage;
    std::vector<double> mat_storage;
    const auto fill = [&](double& value) {
      value = rng.chance(0.8) ? rng.uniform(-10.0, 10.0) : hostile_double(rng);
    };
    const auto mutations = rng.below(6);
    for (std::uint64_t m = 0; m < mutations; ++m) {
      switch (rng.below(8)) {
        case 0:
          s.agent_id = hostile_int<std::int32_t>(rng);
          break;
        case 1:
          mutate_header(s.header, rng);
          break;
        case 2:
          s.target = hostile_int<std::int32_t>(rng);
          break;
        case 7:
          s.world_step = hostile_int<std::int64_t>(rng);
          break;
        case 3:
          reshape(s.info_vec, vec_storage, dds::codec::kMaxInfoDim, rng, fill);
          break;
        case 4:
          reshape(s.info_mat, mat_storage, dds::codec::kMaxInfoMat, rng, fill);
          break;
        case 5:
          if (s.info_vec._length > 0 && s.info_vec._buffer != nullptr)
            s.info_vec._buffer[rng.below(s.info_vec._length)] = hostile_double(rng);
          break;
        default: {
          const auto vec = s.info_vec;
          const auto mat = s.info_mat;
          random_bytes(s, rng);
          s.info_vec = vec;
          s.info_mat = mat;
        }
      }
    }
    const auto decoded = dds::decode(s);
    const std::size_t length = s.info_vec._length;
    const bool buffers_ok = (s.info_vec._length == 0 || s.info_vec._buffer != nullptr) &&
                            (s.info_mat._length == 0 || s.info_mat._buffer != nullptr);
    const bool expect_well_formed =
        buffers_ok && s.agent_id == s.header.agent_id && length <= dds::codec::kMaxInfoDim &&
        s.info_mat._length <= dds::codec::kMaxInfoMat && s.info_mat._length == length * (length + 1) / 2;
    record.check(decoded.well_formed == expect_well_formed, i,
                 "information: well_formed differs from the rule");
    record.check(decoded.message.target == s.target, i, "information: target not carried");
    record.check(decoded.message.world_step == s.world_step, i, "information: world step not carried");
    if (!decoded.well_formed) {
      ++result.rejected;
      continue;
    }
    ++result.accepted;
    const auto& v = decoded.message.info_vec;
    const auto& y = decoded.message.info_mat;
    bool same = static_cast<std::size_t>(v.size()) == length && y.rows() == v.size() && y.cols() == v.size();
    std::size_t next = 0;
    for (Eigen::Index r = 0; same && r < v.size(); ++r) {
      same = same_bits(v(r), s.info_vec._buffer[r]);
      for (Eigen::Index c = r; same && c < v.size(); ++c, ++next) {
        same = same_bits(y(r, c), s.info_mat._buffer[next]) && same_bits(y(c, r), s.info_mat._buffer[next]);
      }
    }
    record.check(same, i, "information: decoded values differ from the wire");
  }
}

// ---------------------------------------------------------------------------------------------------
// Consensus

void fuzz_consensus(std::uint64_t seed, std::uint64_t first, std::uint64_t inputs, FuzzResult& result) {
  Recorder record(result);
  for (std::uint64_t i = first; i < first + inputs; ++i) {
    Rng rng(core::hash_keys(seed, 3, i));
    estimators::ConsensusMessage message;
    message.tau = static_cast<std::int64_t>(rng.below(100));
    message.round = static_cast<std::int32_t>(rng.below(20));
    message.values.resize(rng.below(dds::codec::kMaxConsensusValues + 1));
    for (auto& value : message.values) value = rng.uniform(-5.0, 5.0);
    dds::WireConsensus wire(random_header(rng, 2, static_cast<std::uint32_t>(i)), message);
    swarmloc_msg_Consensus& s = wire.sample;
    std::vector<double> storage;
    const auto mutations = rng.below(6);
    for (std::uint64_t m = 0; m < mutations; ++m) {
      switch (rng.below(6)) {
        case 0:
          s.agent_id = hostile_int<std::int32_t>(rng);
          break;
        case 1:
          mutate_header(s.header, rng);
          break;
        case 2:
          s.tau = hostile_int<std::int64_t>(rng);
          break;
        case 3:
          s.round = hostile_int<std::int32_t>(rng);
          break;
        case 4:
          reshape(s.values, storage, dds::codec::kMaxConsensusValues, rng,
                  [&](double& value) { value = hostile_double(rng); });
          break;
        default: {
          const auto values = s.values;
          random_bytes(s, rng);
          s.values = values;
        }
      }
    }
    const auto decoded = dds::decode(s);
    const bool expect_well_formed = (s.values._length == 0 || s.values._buffer != nullptr) &&
                                    s.values._length <= dds::codec::kMaxConsensusValues &&
                                    s.agent_id == s.header.agent_id;
    record.check(decoded.well_formed == expect_well_formed, i,
                 "consensus: well_formed differs from the rule");
    record.check(decoded.message.tau == s.tau && decoded.message.round == s.round, i,
                 "consensus: tau/round not carried");
    if (!decoded.well_formed) {
      ++result.rejected;
      continue;
    }
    ++result.accepted;
    bool same = decoded.message.values.size() == s.values._length;
    for (std::size_t k = 0; same && k < decoded.message.values.size(); ++k)
      same = same_bits(decoded.message.values[k], s.values._buffer[k]);
    record.check(same, i, "consensus: decoded values differ from the wire");
  }
}

// ---------------------------------------------------------------------------------------------------
// Belief

void fuzz_belief(std::uint64_t seed, std::uint64_t first, std::uint64_t inputs, FuzzResult& result) {
  Recorder record(result);
  for (std::uint64_t i = first; i < first + inputs; ++i) {
    Rng rng(core::hash_keys(seed, 4, i));
    estimators::BeliefMessage message;
    message.iteration = static_cast<std::int64_t>(rng.below(50));
    message.mean_m = Vec2(rng.uniform(-50.0, 50.0), rng.uniform(-50.0, 50.0));
    message.information = random_psd(rng, 3.0);
    message.infinite_information = rng.chance(0.2);
    message.contributions.resize(rng.below(4));  // exact GaBP's per-neighbour messages
    for (auto& c : message.contributions) {
      c.from = static_cast<AgentId>(rng.below(8));
      c.information = random_psd(rng, 2.0);
      c.info_vec = Vec2(rng.uniform(-9.0, 9.0), rng.uniform(-9.0, 9.0));
    }
    const dds::WireBelief wire(random_header(rng, 3, static_cast<std::uint32_t>(i)), message);
    swarmloc_msg_Belief s = wire.sample;
    std::vector<swarmloc_msg_BeliefContribution> storage;
    const auto mutations = rng.below(6);
    for (std::uint64_t m = 0; m < mutations; ++m) {
      switch (rng.below(8)) {
        case 0:
          s.agent_id = hostile_int<std::int32_t>(rng);
          break;
        case 1:
          mutate_header(s.header, rng);
          break;
        case 2:
          s.iteration = hostile_int<std::int64_t>(rng);
          break;
        case 3:
          s.mean_m[rng.below(2)] = hostile_double(rng);
          break;
        case 4:
          s.information[rng.below(3)] = hostile_double(rng);
          break;
        case 5:
          s.infinite_information = rng.chance(0.5);
          break;
        case 6:
          reshape(s.contributions, storage, dds::codec::kMaxBeliefContributions, rng,
                  [&](swarmloc_msg_BeliefContribution& c) {
                    random_bytes(c, rng);
                    if (rng.chance(0.5)) c.information[rng.below(3)] = hostile_double(rng);
                  });
          break;
        default: {
          const auto contributions = s.contributions;  // random pointers would be read
          random_bytes(s, rng);
          s.contributions = contributions;
          s.infinite_information = rng.chance(0.5);  // CDR booleans are 0 or 1
        }
      }
    }
    const auto decoded = dds::decode(s);
    const bool expect_well_formed = (s.contributions._length == 0 || s.contributions._buffer != nullptr) &&
                                    s.contributions._length <= dds::codec::kMaxBeliefContributions &&
                                    s.agent_id == s.header.agent_id;
    record.check(decoded.well_formed == expect_well_formed, i, "belief: well_formed differs from the rule");
    if (!decoded.well_formed) {
      ++result.rejected;
      continue;
    }
    ++result.accepted;
    const auto& b = decoded.message;
    record.check(same_bits(b.mean_m.x(), s.mean_m[0]) && same_bits(b.mean_m.y(), s.mean_m[1]) &&
                     same_bits(b.information(0, 0), s.information[0]) &&
                     same_bits(b.information(0, 1), s.information[1]) &&
                     same_bits(b.information(1, 0), s.information[1]) &&
                     same_bits(b.information(1, 1), s.information[2]) &&
                     b.infinite_information == s.infinite_information && b.iteration == s.iteration,
                 i, "belief: decoded values differ from the wire");
    bool same = b.contributions.size() == s.contributions._length;
    for (std::size_t k = 0; same && k < b.contributions.size(); ++k) {
      const auto& wire_c = s.contributions._buffer[k];
      const auto& c = b.contributions[k];
      same = c.from == wire_c.from && same_bits(c.info_vec.x(), wire_c.info_vec[0]) &&
             same_bits(c.info_vec.y(), wire_c.info_vec[1]) &&
             same_bits(c.information(0, 0), wire_c.information[0]) &&
             same_bits(c.information(0, 1), wire_c.information[1]) &&
             same_bits(c.information(1, 0), wire_c.information[1]) &&
             same_bits(c.information(1, 1), wire_c.information[2]);
    }
    record.check(same, i, "belief: decoded contributions differ from the wire");
  }
}

// ---------------------------------------------------------------------------------------------------
// Measurement batch (orchestrator -> agent), then into the runtime and one estimator step

void fuzz_batch(std::uint64_t seed, std::uint64_t first, std::uint64_t inputs, FuzzResult& result) {
  Recorder record(result);
  std::unique_ptr<runtime::AgentRuntime> runtime;
  for (std::uint64_t i = first; i < first + inputs; ++i) {
    Rng rng(core::hash_keys(seed, 5, i));
    if (runtime == nullptr || i % kSession == 0 || i == first) {
      runtime =
          std::make_unique<runtime::AgentRuntime>(make_runtime(seed, rng.chance(0.5) ? "ieif" : "iekf"));
      // Neighbours with known states, so ranges to them are used.
      for (const AgentId peer : kNeighbours) {
        estimators::StateMessage anchor;
        anchor.anchor = true;
        anchor.mean_m = Vec2(10.0 * peer, 3.0 * peer);
        runtime->on_state(random_header(rng, peer, 0), anchor);
      }
    }
    auto batch = plausible_batch(rng, static_cast<std::int64_t>(i % kSession));
    if (rng.chance(0.3))
      batch.fix = estimators::AbsoluteFix{Vec2(rng.uniform(0, 40), rng.uniform(0, 40)), random_psd(rng, 1.0),
                                          std::nullopt};
    if (rng.chance(0.3))
      batch.motion =
          estimators::MotionInput{Vec2(rng.uniform(-1, 1), rng.uniform(-1, 1)), 0.1, random_psd(rng, 0.1)};
    dds::WireBatch wire(kSelf, random_header(rng, kOrchestratorId, static_cast<std::uint32_t>(i)), batch);
    swarmloc_msg_MeasurementBatch s = wire.sample;
    std::vector<swarmloc_msg_Range> ranges;
    std::vector<swarmloc_msg_AbsoluteFix> fixes;
    std::vector<double> fix_z;
    std::vector<swarmloc_msg_MotionInput> motion;
    std::vector<std::int32_t> neighbours;
    std::vector<swarmloc_msg_OdometrySegment> odometry;
    std::vector<swarmloc_msg_RangeBearing> range_bearings;
    const auto mutations = rng.below(6);
    for (std::uint64_t m = 0; m < mutations; ++m) {
      switch (rng.below(10)) {
        case 0:
          s.agent_id = hostile_int<std::int32_t>(rng);
          break;
        case 1:
          mutate_header(s.header, rng);
          break;
        case 2:
          reshape(s.ranges, ranges, 64, rng, [&](swarmloc_msg_Range& range) {
            range.peer = rng.chance(0.7) ? kNeighbours[rng.below(3)] : hostile_int<std::int32_t>(rng);
            range.range_m = rng.chance(0.5) ? rng.uniform(0.0, 20.0) : hostile_double(rng);
            range.std_m = rng.chance(0.5) ? 0.1 : hostile_double(rng);
          });
          break;
        case 3:
          reshape(s.fixes, fixes, 1, rng, [&](swarmloc_msg_AbsoluteFix& fix) {
            for (auto& v : fix.position_m) v = hostile_double(rng);
            for (auto& v : fix.covariance) v = hostile_double(rng);
          });
          reshape(s.fix_z, fix_z, 2, rng, [&](double& z) { z = hostile_double(rng); });
          break;
        case 4:
          reshape(s.motion, motion, 1, rng, [&](swarmloc_msg_MotionInput& input) {
            for (auto& v : input.velocity_mps) v = hostile_double(rng);
            input.dt_s = hostile_double(rng);
            for (auto& v : input.process_cov) v = hostile_double(rng);
          });
          break;
        case 5:
          reshape(s.neighbours, neighbours, 16, rng,
                  [&](std::int32_t& id) { id = hostile_int<std::int32_t>(rng); });
          break;
        case 6:
          if (s.ranges._length > 0 && s.ranges._buffer != nullptr) {
            auto& range = s.ranges._buffer[rng.below(s.ranges._length)];
            (rng.chance(0.5) ? range.range_m : range.std_m) = hostile_double(rng);
          }
          break;
        case 7:
          if (s.fixes._length > 0 && s.fixes._buffer != nullptr)
            s.fixes._buffer[0].covariance[rng.below(3)] = hostile_double(rng);
          break;
        case 8:
          s.has_odometry = rng.chance(0.5);
          reshape(s.odometry, odometry, 8, rng, [&](swarmloc_msg_OdometrySegment& segment) {
            segment.v_mps = hostile_double(rng);
            segment.omega_radps = hostile_double(rng);
            segment.dt_s = hostile_double(rng);
          });
          s.odometry_v_std = hostile_double(rng);
          reshape(s.range_bearings, range_bearings, 8, rng, [&](swarmloc_msg_RangeBearing& pair) {
            pair.peer = rng.chance(0.7) ? kNeighbours[rng.below(3)] : hostile_int<std::int32_t>(rng);
            pair.landmark = rng.chance(0.5);
            for (auto& v : pair.landmark_m) v = hostile_double(rng);
            for (auto& v : pair.landmark_cov) v = hostile_double(rng);
            pair.range_m = hostile_double(rng);
            pair.bearing_rad = hostile_double(rng);
            pair.range_std_m = hostile_double(rng);
            pair.bearing_std_rad = hostile_double(rng);
          });
          break;
        default: {
          const auto saved = s;
          random_bytes(s, rng);
          s.ranges = saved.ranges;
          s.bearings = saved.bearings;
          s.relative = saved.relative;
          s.fixes = saved.fixes;
          s.fix_z = saved.fix_z;
          s.targets = saved.targets;
          s.paths = saved.paths;
          s.motion = saved.motion;
          s.neighbours = saved.neighbours;
          s.has_odometry = saved.has_odometry;  // a bool's bytes must stay 0 or 1
          s.odometry = saved.odometry;
          s.range_bearings = saved.range_bearings;
        }
      }
    }
    const auto decoded = dds::decode(s);
    const auto buffer_ok = [](const auto& sequence) {
      return sequence._length == 0 || sequence._buffer != nullptr;
    };
    const bool expect_well_formed = buffer_ok(s.ranges) && buffer_ok(s.fixes) && buffer_ok(s.motion) &&
                                    buffer_ok(s.neighbours) && buffer_ok(s.odometry) &&
                                    buffer_ok(s.range_bearings) && buffer_ok(s.fix_z) &&
                                    s.fixes._length <= 1 && s.fix_z._length <= s.fixes._length &&
                                    s.motion._length <= 1 && (s.has_odometry || s.odometry._length == 0);
    record.check(decoded.well_formed == expect_well_formed, i, "batch: well_formed differs from the rule");
    record.check(decoded.recipient == s.agent_id && decoded.batch.world_step == s.header.step, i,
                 "batch: recipient/step not carried");
    if (!decoded.well_formed) {
      ++result.rejected;
      continue;
    }
    ++result.accepted;
    record.check(decoded.batch.ranges.size() == s.ranges._length &&
                     decoded.batch.fix.has_value() == (s.fixes._length == 1) &&
                     (decoded.batch.fix && decoded.batch.fix->z_m.has_value()) == (s.fix_z._length == 1) &&
                     decoded.batch.motion.has_value() == (s.motion._length == 1) &&
                     decoded.batch.neighbours.size() == s.neighbours._length,
                 i, "batch: decoded sizes differ from the wire");
    runtime->on_batch(decoded.header, decoded.batch);
    (void)runtime->step(static_cast<std::int64_t>(i));
    if (!estimate_is_finite(*runtime)) {
      record.violation(i, "batch: the estimate became non-finite");
      runtime.reset();  // start a fresh agent so one finding does not repeat for the whole session
    }
  }
}

// ---------------------------------------------------------------------------------------------------
// Estimate (agent -> orchestrator) and Control (orchestrator -> agents)

void fuzz_estimate(std::uint64_t seed, std::uint64_t first, std::uint64_t inputs, FuzzResult& result) {
  Recorder record(result);
  for (std::uint64_t i = first; i < first + inputs; ++i) {
    Rng rng(core::hash_keys(seed, 6, i));
    runtime::EstimateReport report;
    report.header = random_header(rng, static_cast<AgentId>(rng.below(30)), static_cast<std::uint32_t>(i));
    report.estimate.mean_m = Vec2(rng.uniform(-50, 50), rng.uniform(-50, 50));
    report.estimate.covariance = random_psd(rng, 1.0);
    report.estimate.valid = rng.chance(0.9);
    report.estimate.inconsistent = rng.chance(0.1);
    report.steps_run = static_cast<std::uint32_t>(rng.below(300));
    report.links.resize(rng.below(6));
    for (auto& link : report.links) link.sender = static_cast<AgentId>(rng.below(30));
    dds::WireEstimate wire(report);
    swarmloc_msg_Estimate& s = wire.sample;
    std::vector<swarmloc_msg_LinkCounters> links;
    std::vector<std::uint32_t> reasons;
    std::vector<double> field;
    const auto mutations = rng.below(6);
    for (std::uint64_t m = 0; m < mutations; ++m) {
      switch (rng.below(10)) {
        case 0:
          s.agent_id = hostile_int<std::int32_t>(rng);
          break;
        case 1:
          mutate_header(s.header, rng);
          break;
        case 8:
          // Run health: durations and counts a hostile agent may bend.
          s.health.ticks = hostile_int<std::uint32_t>(rng);
          s.health.late_ticks = hostile_int<std::uint32_t>(rng);
          s.health.batches_merged = hostile_int<std::uint32_t>(rng);
          s.health.max_tick_lateness_s = hostile_double(rng);
          s.health.neighbour_age_mean_s = hostile_double(rng);
          break;
        case 2:
          s.mean_m[rng.below(2)] = hostile_double(rng);
          break;
        case 3:
          s.covariance[rng.below(3)] = hostile_double(rng);
          break;
        case 4:
          s.cpu_s = hostile_double(rng);
          break;
        case 5:
          reshape(s.links, links, 100, rng,
                  [&](swarmloc_msg_LinkCounters& link) { random_bytes(link, rng); });
          break;
        case 6:
          reshape(s.rejected_by_reason, reasons, dds::codec::kMaxRejectReasons, rng,
                  [&](std::uint32_t& count) { count = hostile_int<std::uint32_t>(rng); });
          break;
        case 7:
          reshape(s.field, field, dds::codec::kMaxFieldValues, rng,
                  [&](double& value) { value = hostile_double(rng); });
          break;
        default: {
          const auto saved_links = s.links;
          const auto saved_reasons = s.rejected_by_reason;
          const auto saved_field = s.field;
          random_bytes(s, rng);
          s.valid = rng.chance(0.5);
          s.inconsistent = rng.chance(0.5);  // a bool holds 0 or 1: the reader's deserializer ensures it
          s.links = saved_links;
          s.rejected_by_reason = saved_reasons;
          s.field = saved_field;
        }
      }
    }
    const auto decoded = dds::decode(s);
    const auto duration = [](double d) { return std::isfinite(d) && d >= 0.0 && d < 1e9; };
    const auto& h = s.health;
    const bool health_ok = duration(h.max_tick_lateness_s) && duration(h.mean_tick_lateness_s) &&
                           duration(h.max_batch_wait_s) && duration(h.neighbour_age_mean_s) &&
                           duration(h.neighbour_age_max_s) && h.late_ticks <= h.ticks &&
                           h.batches_merged <= h.batches_received;
    const bool expect_well_formed =
        health_ok && (s.links._length == 0 || s.links._buffer != nullptr) &&
        (s.rejected_by_reason._length == 0 || s.rejected_by_reason._buffer != nullptr) &&
        (s.field._length == 0 || s.field._buffer != nullptr) &&
        s.field._length <= dds::codec::kMaxFieldValues &&
        s.rejected_by_reason._length <= runtime::kRejectReasonCount && s.agent_id == s.header.agent_id;
    record.check(decoded.well_formed == expect_well_formed, i, "estimate: well_formed differs from the rule");
    if (!decoded.well_formed) {
      ++result.rejected;
      continue;
    }
    ++result.accepted;
    bool same = decoded.report.links.size() == s.links._length &&
                decoded.report.estimate.inconsistent == s.inconsistent;
    for (std::size_t k = 0; same && k < s.rejected_by_reason._length; ++k)
      same = decoded.report.rejected_by_reason[k] == s.rejected_by_reason._buffer[k];
    same = same && decoded.report.estimate.field.size() == static_cast<Eigen::Index>(s.field._length);
    for (std::size_t k = 0; same && k < s.field._length; ++k) {  // bit for bit: NaN and ±0 pass through
      same = std::memcmp(&decoded.report.estimate.field(static_cast<Eigen::Index>(k)), &s.field._buffer[k],
                         sizeof(double)) == 0;
    }
    record.check(same, i, "estimate: decoded values differ from the wire");
  }
}

void fuzz_control(std::uint64_t seed, std::uint64_t first, std::uint64_t inputs, FuzzResult& result) {
  Recorder record(result);
  for (std::uint64_t i = first; i < first + inputs; ++i) {
    Rng rng(core::hash_keys(seed, 7, i));
    runtime::ControlMessage message;
    message.header = random_header(rng, kOrchestratorId, static_cast<std::uint32_t>(i));
    message.command = static_cast<runtime::ControlCommand>(rng.below(4));
    message.scenario_hash = rng.next();
    const dds::WireControl wire(message);
    swarmloc_msg_Control s = wire.sample;
    const auto mutations = rng.below(4);
    for (std::uint64_t m = 0; m < mutations; ++m) {
      switch (rng.below(4)) {
        case 0:
          s.command = hostile_int<std::uint8_t>(rng);
          break;
        case 1:
          mutate_header(s.header, rng);
          break;
        case 2:
          s.agent_id = hostile_int<std::int32_t>(rng);
          break;
        default:
          random_bytes(s, rng);
      }
    }
    const auto decoded = dds::decode(s);
    const bool known = s.command == swarmloc_msg_CONTROL_HELLO || s.command == swarmloc_msg_CONTROL_START ||
                       s.command == swarmloc_msg_CONTROL_STOP || s.command == swarmloc_msg_CONTROL_REFUSE;
    record.check(decoded.well_formed == known, i, "control: well_formed differs from the command rule");
    record.check(decoded.message.scenario_hash == s.scenario_hash && decoded.message.target == s.agent_id, i,
                 "control: fields not carried");
    if (decoded.well_formed) {
      ++result.accepted;
      record.check(static_cast<std::uint8_t>(decoded.message.command) == s.command, i,
                   "control: command changed");
    } else {
      ++result.rejected;
    }
  }
}

// ---------------------------------------------------------------------------------------------------
// Scenario parser

const std::vector<std::string>& scenario_corpus() {
  static const std::vector<std::string> corpus = [] {
    std::vector<std::string> texts;
#ifdef SWARMLOC_SOURCE_DIR
    for (const char* file : {"/scenarios/default.yaml", "/scenarios/ea2.yaml"}) {
      std::ifstream in(std::string(SWARMLOC_SOURCE_DIR) + file);
      std::stringstream buffer;
      buffer << in.rdbuf();
      if (!buffer.str().empty()) texts.push_back(buffer.str());
    }
#endif
    config::Scenario s;
    texts.push_back(config::to_yaml(s));
    s.name = "fuzz: \"quoted\" \\ #";
    s.network.loss = 0.3;
    s.network.burst.mean_length = 8.0;
    s.run.mode = config::RunMode::kLockstep;
    s.world.placement = config::Placement::kGrid;
    s.qos.state.reliability = config::Reliability::kReliable;
    texts.push_back(config::to_yaml(s));
    texts.emplace_back("seed: 7\nworld:\n  agents: 12\n  anchors: 4\nnetwork:\n  loss: 0.2\n");
    texts.emplace_back(
        "{world: {agents: 5, anchors: 3}, network: {loss: 0.1, burst: {mean_length: 3}}, "
        "run: {steps: 10, mode: free-run}}\n");
    texts.emplace_back(
        "# comment\nalgorithm:\n  name: iekf   # trailing\n  initial_std_m: 1e1\nqos:\n"
        "  state: {reliability: reliable, history_depth: 2}\n");
    texts.emplace_back("");
    return texts;
  }();
  return corpus;
}

constexpr std::array<std::string_view, 44> kValues{"1e999",
                                                   "-1e999",
                                                   "99999999999999999999999",
                                                   "-2147483649",
                                                   "2147483648",
                                                   "18446744073709551616",
                                                   "0x1F",
                                                   "0o17",
                                                   "1_000",
                                                   ".nan",
                                                   ".inf",
                                                   "-.inf",
                                                   "~",
                                                   "null",
                                                   "",
                                                   "''",
                                                   "\"\"",
                                                   "[1, 2]",
                                                   "{a: 1}",
                                                   "yes",
                                                   "No",
                                                   "true",
                                                   "1e-320",
                                                   "4.9e-324",
                                                   "1.7976931348623157e308",
                                                   "-0",
                                                   "+5",
                                                   "0.5",
                                                   "30",
                                                   "lockstep",
                                                   "free-run",
                                                   "\"300\"",
                                                   "'x: y'",
                                                   "&x 5",
                                                   "*x",
                                                   "!!int 5",
                                                   "!!str 5",
                                                   "|\n  multi\n",
                                                   "- 1\n- 2",
                                                   "1.5",
                                                   "-1",
                                                   "0",
                                                   "ieif",
                                                   "reliable"};

constexpr std::array<std::string_view, 24> kTokens{
    ":",  "-", " ", "\n", "\t", "#",  "[", "]",     "{",     "}",  ",",        "&a ",
    "*a", "!", "|", ">",  "'",  "\"", "%", "---\n", "...\n", "? ", "<<: *a\n", std::string_view("\0", 1)};

std::string random_value(Rng& rng) {
  if (rng.chance(0.2)) return std::to_string(static_cast<std::int64_t>(rng.next()));
  if (rng.chance(0.1)) return std::string(1 + rng.below(2000), 'x');
  return std::string(kValues[rng.below(kValues.size())]);
}

std::string random_key(Rng& rng) {
  const auto& keys = config::known_keys();
  std::string key = keys[rng.below(keys.size())];
  if (rng.chance(0.6)) key = key.substr(key.rfind('.') + 1);  // leaf name, as in a file
  if (rng.chance(0.1)) key[rng.below(key.size())] = static_cast<char>('a' + rng.below(26));  // typo
  return key;
}

std::vector<std::size_t> line_starts(const std::string& text) {
  std::vector<std::size_t> starts{0};
  for (std::size_t p = 0; p < text.size(); ++p)
    if (text[p] == '\n' && p + 1 < text.size()) starts.push_back(p + 1);
  return starts;
}

void mutate_text(std::string& text, Rng& rng) {
  const auto position = [&] { return text.empty() ? std::size_t{0} : rng.below(text.size() + 1); };
  switch (rng.below(11)) {
    case 0:
      if (!text.empty()) text[rng.below(text.size())] ^= static_cast<char>(1U << rng.below(8));
      break;
    case 1:
      if (!text.empty()) text[rng.below(text.size())] = static_cast<char>(rng.next());
      break;
    case 2:
      text.insert(position(), std::string(kTokens[rng.below(kTokens.size())]));
      break;
    case 3:
      if (!text.empty()) {
        const auto at = rng.below(text.size());
        text.erase(at, 1 + rng.below(16));
      }
      break;
    case 4:
      text.resize(position());
      break;
    case 5:
    case 6: {
      const auto starts = line_starts(text);
      const auto a = starts[rng.below(starts.size())];
      const auto a_end = text.find('\n', a);
      const std::string line = text.substr(a, a_end == std::string::npos ? std::string::npos : a_end - a + 1);
      const auto b = starts[rng.below(starts.size())];
      if (rng.chance(0.5)) {
        text.insert(b, line);  // duplicate a line (duplicate keys, repeated sections)
      } else {
        text.erase(a, line.size());  // move a line elsewhere
        text.insert(std::min(b, text.size()), line);
      }
      break;
    }
    case 7:
    case 8: {
      const auto starts = line_starts(text);
      const auto at = starts[rng.below(starts.size())];
      text.insert(at, std::string(2 * rng.below(4), ' ') + random_key(rng) + ": " + random_value(rng) + "\n");
      break;
    }
    case 9: {
      const auto colon = text.find(": ", position());
      if (colon != std::string::npos) {
        const auto end = text.find('\n', colon);
        text.replace(colon + 2, (end == std::string::npos ? text.size() : end) - colon - 2,
                     random_value(rng));
      }
      break;
    }
    default:
      text.insert(position(), std::string(1 + rng.below(3), static_cast<char>(rng.next())));
  }
}

}  // namespace

ScenarioInput scenario_input(std::uint64_t seed, std::uint64_t i) {
  const auto& corpus = scenario_corpus();
  {
    Rng rng(core::hash_keys(seed, 8, i));
    std::string text = corpus[rng.below(corpus.size())];
    const auto mutations = 1 + rng.below(6);
    for (std::uint64_t m = 0; m < mutations; ++m) mutate_text(text, rng);
    std::vector<std::string> overrides;
    if (rng.chance(0.15)) {
      const auto& keys = config::known_keys();
      for (std::uint64_t k = 0, n = 1 + rng.below(2); k < n; ++k) {
        std::string key = keys[rng.below(keys.size())];
        if (rng.chance(0.1)) key = random_key(rng);
        overrides.push_back(rng.chance(0.05) ? key : key + "=" + random_value(rng));
      }
    }
    return {text, overrides};
  }
}

namespace {

void fuzz_scenario(std::uint64_t seed, std::uint64_t first, std::uint64_t inputs, FuzzResult& result) {
  Recorder record(result);
  for (std::uint64_t i = first; i < first + inputs; ++i) {
    const auto [text, overrides] = scenario_input(seed, i);
    try {
      const config::Scenario scenario = config::parse_scenario(text, overrides, "fuzz.yaml");
      ++result.accepted;
      try {
        config::validate(scenario);
        const std::string yaml = config::to_yaml(scenario);
        const config::Scenario again = config::parse_scenario(yaml);
        record.check(config::to_yaml(again) == yaml, i, "scenario: to_yaml round trip differs");
      } catch (const std::exception& error) {
        record.violation(
            i, std::string("scenario: a parsed scenario failed validate/round trip: ") + error.what());
      }
    } catch (const config::ScenarioError&) {
      ++result.rejected;
    } catch (const std::exception& error) {
      record.violation(i, std::string("scenario: threw ") + typeid(error).name() +
                              " (not ScenarioError): " + error.what());
    } catch (...) {
      record.violation(i, "scenario: threw a non-std exception");
    }
  }
}

using TargetFn = void (*)(std::uint64_t, std::uint64_t, std::uint64_t, FuzzResult&);

const std::vector<std::pair<std::string, TargetFn>>& targets() {
  static const std::vector<std::pair<std::string, TargetFn>> list{
      {"state", fuzz_state},         {"information", fuzz_information},
      {"consensus", fuzz_consensus}, {"belief", fuzz_belief},
      {"batch", fuzz_batch},         {"estimate", fuzz_estimate},
      {"control", fuzz_control},     {"scenario", fuzz_scenario}};
  return list;
}

}  // namespace

const std::vector<std::string>& target_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> list;
    for (const auto& [name, fn] : targets()) list.push_back(name);
    return list;
  }();
  return names;
}

FuzzResult run_target(const std::string& target, std::uint64_t seed, std::uint64_t inputs,
                      std::uint64_t first) {
  for (const auto& [name, fn] : targets()) {
    if (name != target) continue;
    FuzzResult result;
    result.target = name;
    result.inputs = inputs;
    fn(seed, first, inputs, result);
    return result;
  }
  throw std::invalid_argument("unknown fuzz target '" + target + "'");
}

}  // namespace swarmloc::fuzz
