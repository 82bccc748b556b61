#pragma once
// The IDL-free face of the conversion layer (convert.cpp is the one file that converts IDL <-> swarmloc
// types). It holds the field-level rules shared by every family — Sym2 packing, upper-triangle packing,
// flag/enum ranges, sequence bounds — and round trips through the IDL structs for the unit tests, which
// cannot include the generated "swarmloc.h" (swarmloc_idl is linked privately into swarmloc_dds).
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "swarmloc/dds/transport.hpp"

namespace swarmloc::dds::codec {

// Bounds of the IDL's bounded sequences (idl/swarmloc.idl).
inline constexpr std::size_t kMaxInfoDim = 64;
inline constexpr std::size_t kMaxInfoMat = 2080;  // 64 * 65 / 2
inline constexpr std::size_t kMaxConsensusValues = 16;
inline constexpr std::size_t kMaxRejectReasons = 16;
/// Estimate.field's bound in the IDL: joint_field's field has at most 64 cells.
inline constexpr std::size_t kMaxFieldValues = 64;
/// Belief.contributions' bound: exact GaBP's messages, one per neighbour.
inline constexpr std::size_t kMaxBeliefContributions = 1024;
inline constexpr std::size_t kMaxEdgeRanges = 16;
/// State.cavities' bound: dml's cavities, one per neighbour.
inline constexpr std::size_t kMaxCavities = 64;
static_assert(kMaxCavities == estimators::StateMessage::kMaxCavities);
/// Observations' bounds (team_pose_ekf).
inline constexpr std::size_t kMaxObservedSpans = 64;
inline constexpr std::size_t kMaxSpanOdometry = 1024;
inline constexpr std::size_t kMaxSpanRangeBearings = 256;

inline constexpr std::uint8_t kStateFlagAnchor = 1;        // STATE_FLAG_ANCHOR
inline constexpr std::uint8_t kStateFlagActive = 2;        // STATE_FLAG_ACTIVE
inline constexpr std::uint8_t kStateFlagInconsistent = 4;  // STATE_FLAG_INCONSISTENT
inline constexpr std::uint8_t kStateFlagsKnown = kStateFlagAnchor | kStateFlagActive | kStateFlagInconsistent;

/// Sym2: the upper triangle xx, xy, yy. Unpacking yields an exactly symmetric matrix.
std::array<double, 3> pack_sym2(const Mat2& matrix);
Mat2 unpack_sym2(std::span<const double, 3> packed);

/// Upper triangle of an n x n matrix, row-major: (0,0) (0,1) … (0,n-1) (1,1) … (n-1,n-1).
std::vector<double> pack_upper(const MatX& matrix);
/// nullopt unless packed.size() == n (n + 1) / 2.
std::optional<MatX> unpack_upper(std::span<const double> packed, std::size_t n);

/// A 3-D position's z part is usable: finite, var(z) >= 0, and the (x, y, z) covariance
/// join(planar_covariance, altitude) symmetric PSD (what the orchestrator asks of an Estimate's).
bool plausible_altitude(const Mat2& planar_covariance, const Altitude& altitude);

std::uint8_t state_flags(const estimators::StateMessage& message);
/// False if flags has bits other than ANCHOR | ACTIVE | INCONSISTENT set (message left untouched then).
bool apply_state_flags(std::uint8_t flags, estimators::StateMessage& message);
std::optional<runtime::ControlCommand> control_command(std::uint8_t wire);

/// Decodes Information from its fields; well_formed is false if info_vec is longer than 64, info_mat
/// longer than 2080, or info_mat.size() != n (n + 1) / 2 with n = info_vec.size(), or key != sender.
Inbound<estimators::InformationMessage> decode_information_fields(const runtime::Header& header, AgentId key,
                                                                  std::int32_t target,
                                                                  std::span<const double> info_vec,
                                                                  std::span<const double> info_mat);

/// A measurement batch as taken (recipient = the topic key).
struct DecodedBatch {
  AgentId recipient = 0;
  runtime::Header header;
  estimators::MeasurementBatch batch;
  bool well_formed = true;
};
struct DecodedEstimate {
  runtime::EstimateReport report;
  bool well_formed = true;
};
struct DecodedControl {
  runtime::ControlMessage message;
  bool well_formed = true;
};

// Round trips swarmloc -> IDL sample -> swarmloc through the exact code dds_write / dds_take use.
Inbound<estimators::StateMessage> round_trip(const runtime::Header& header,
                                             const estimators::StateMessage& message);
Inbound<estimators::InformationMessage> round_trip(const runtime::Header& header,
                                                   const estimators::InformationMessage& message);
Inbound<estimators::ConsensusMessage> round_trip(const runtime::Header& header,
                                                 const estimators::ConsensusMessage& message);
Inbound<estimators::BeliefMessage> round_trip(const runtime::Header& header,
                                              const estimators::BeliefMessage& message);
Inbound<estimators::ObservationMessage> round_trip(const runtime::Header& header,
                                                   const estimators::ObservationMessage& message);
DecodedBatch round_trip(AgentId recipient, const runtime::Header& header,
                        const estimators::MeasurementBatch& batch);
DecodedEstimate round_trip(const runtime::EstimateReport& report);
DecodedControl round_trip(const runtime::ControlMessage& message);
/// The State round trip with the wire's edge_peer_z replaced (a garbled or hostile writer's sample).
Inbound<estimators::StateMessage> round_trip_with_edge_peer_z(const runtime::Header& header,
                                                              const estimators::StateMessage& message,
                                                              std::vector<double> edge_peer_z);
/// The State round trip with the wire's cavities and cavity_offset_z replaced, unchecked (any count: a
/// garbled or hostile writer's sample).
Inbound<estimators::StateMessage> round_trip_with_cavities(
    const runtime::Header& header, const estimators::StateMessage& message,
    const std::vector<estimators::EdgeCavity>& cavities, std::vector<double> cavity_offset_z);
/// The State sample's XCDR1 size in bytes, without the 4-byte encapsulation header before it.
std::size_t state_xcdr1_size(const runtime::Header& header, const estimators::StateMessage& message);

}  // namespace swarmloc::dds::codec
