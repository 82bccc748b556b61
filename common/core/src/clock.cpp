#include "swarmloc/core/clock.hpp"

#include "swarmloc/core/random.hpp"

namespace swarmloc::core {

ClockModel draw_clock(std::uint64_t seed, std::int32_t id, double offset_max_s, double drift_ppm) {
  const double u_offset = unit_uniform(hash_keys(seed, static_cast<std::uint64_t>(Stream::kClock), id, 0));
  const double u_drift = unit_uniform(hash_keys(seed, static_cast<std::uint64_t>(Stream::kClock), id, 1));
  return ClockModel{offset_max_s * (2.0 * u_offset - 1.0), drift_ppm * (2.0 * u_drift - 1.0)};
}

}  // namespace swarmloc::core
