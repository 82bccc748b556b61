#pragma once
// The UWB team's IDL samples (uwb_team.h) <-> plain types (uwb_team_io.hpp), as convert.hpp does for the
// swarmloc families: a Wire… holds the IDL sample and the buffers its sequences point into (it must outlive
// the dds_write and is neither copyable nor movable); accept(...) decodes a received sample and checks it
// against the rules of uwb_team_codec.hpp, never throwing on bad content.
#include <vector>

#include "uwb_team.h"
#include "uwb_team_codec.hpp"

namespace swarmloc::dds {

struct WireWindowInput {
  /// Throws DdsError when the input exceeds the IDL's bounds.
  explicit WireWindowInput(const UwbWindowInput& input);
  WireWindowInput(const WireWindowInput&) = delete;
  WireWindowInput& operator=(const WireWindowInput&) = delete;
  std::vector<std::vector<double>> ranges_m;  ///< per peer, row-major
  std::vector<std::vector<double>> spread_m;
  std::vector<swarmloc_uwb_PeerRangeWindow> windows;
  swarmloc_uwb_WindowInput sample{};
};

swarmloc_uwb_Sensing wire_sensing(const UwbSensing& sensing);

struct WireEstimates {
  explicit WireEstimates(const UwbEstimates& estimates);
  WireEstimates(const WireEstimates&) = delete;
  WireEstimates& operator=(const WireEstimates&) = delete;
  std::vector<swarmloc_uwb_PeerPose> peers;
  swarmloc_uwb_Estimates sample{};
};

uwb_codec::Problem accept(const swarmloc_uwb_WindowInput& wire, const std::vector<AgentId>& team,
                          UwbWindowInput& out);
uwb_codec::Problem accept(const swarmloc_uwb_Sensing& wire, const std::vector<AgentId>& team,
                          UwbSensing& out);
uwb_codec::Problem accept(const swarmloc_uwb_Estimates& wire, const std::vector<AgentId>& team,
                          UwbEstimates& out);

}  // namespace swarmloc::dds
