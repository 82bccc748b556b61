#pragma once
// Per-agent clock model (docs/design.md §2): t_i = offset_i + (1 + drift_i)·t_mono. Pure arithmetic; the
// runtime feeds it monotonic time.
#include <cstdint>

namespace swarmloc::core {

struct ClockModel {
  double offset_s = 0.0;   ///< added to the local reading
  double drift_ppm = 0.0;  ///< rate error in parts per million

  [[nodiscard]] double local_time(double mono_s) const {
    return offset_s + (1.0 + drift_ppm * 1e-6) * mono_s;
  }
  /// Monotonic duration that elapses while the local clock advances by `local_dt_s`.
  [[nodiscard]] double mono_duration(double local_dt_s) const {
    return local_dt_s / (1.0 + drift_ppm * 1e-6);
  }
};

/// Draws agent `id`'s clock from the seed: offset ~ U[-offset_max, offset_max], drift ~ U[-ppm, ppm].
ClockModel draw_clock(std::uint64_t seed, std::int32_t id, double offset_max_s, double drift_ppm);

}  // namespace swarmloc::core
