#pragma once
// Seeded, counter-based randomness. Every stochastic decision in swarmloc is a pure function of
// (seed, stream, indices), so the simulator and the DDS runtime draw identical numbers in any order.
#include <cmath>
#include <cstdint>
#include <random>

namespace swarmloc::core {

/// SplitMix64 finalizer: a strong 64-bit mix.
constexpr std::uint64_t mix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30U)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27U)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31U);
}

/// Hash of a seed and any number of integer keys.
template <typename... Keys>
constexpr std::uint64_t hash_keys(std::uint64_t seed, Keys... keys) {
  std::uint64_t h = mix64(seed);
  ((h = mix64(h ^ static_cast<std::uint64_t>(static_cast<std::int64_t>(keys)))), ...);
  return h;
}

/// Uniform in [0, 1) from a hash (53 random bits).
constexpr double unit_uniform(std::uint64_t h) {
  return static_cast<double>(h >> 11U) * (1.0 / 9007199254740992.0);
}

/// Standard normal from a hash (Box–Muller on two 53-bit uniforms). Counter-based: no engine to seed,
/// which matters on hot paths that draw one number per (step, agent, peer).
inline double standard_normal(std::uint64_t h) {
  const double u1 = 1.0 - unit_uniform(mix64(h));  // (0, 1]: log is finite
  const double u2 = unit_uniform(mix64(h ^ 0x5851f42d4c957f2dULL));
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
}

/// Named random streams so that adding draws to one purpose never shifts another.
enum class Stream : std::uint64_t {
  kPlacement = 1,
  kAnchors = 2,
  kInitialGuess = 3,
  kMeasurementNoise = 4,
  kMotion = 5,
  kLinkLoss = 6,
  kClock = 7,
  kDelay = 8,
  kLinkBurst = 9,  ///< Gilbert–Elliott link state (link_model.hpp)
};

/// A standard engine seeded from (seed, stream, extra keys).
template <typename... Keys>
std::mt19937_64 make_engine(std::uint64_t seed, Stream stream, Keys... keys) {
  return std::mt19937_64(hash_keys(seed, static_cast<std::uint64_t>(stream), keys...));
}

}  // namespace swarmloc::core
