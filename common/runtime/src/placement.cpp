#include "swarmloc/runtime/placement.hpp"

#include <algorithm>
#include <array>

namespace swarmloc::sim {

namespace {
constexpr std::array<std::string_view, 4> kCentralizedAlgorithms{"ekf", "lbekf", "lbekf_vr", "lbekf_i"};
}  // namespace

bool is_centralized(std::string_view algorithm) {
  return std::find(kCentralizedAlgorithms.begin(), kCentralizedAlgorithms.end(), algorithm) !=
         kCentralizedAlgorithms.end();
}

}  // namespace swarmloc::sim
