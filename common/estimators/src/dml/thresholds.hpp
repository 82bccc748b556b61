#pragma once
// Thresholds of dml's start and self-check shared by its source files (docs/algorithms.md §9.4, §9.5, §9.9).

#include "swarmloc/estimators/self_check.hpp"

namespace swarmloc::estimators::dml_thresholds {

inline constexpr double kSelfCheckFalseAlarm = 1e-6;  // per agent and step: a healthy network never flags
inline constexpr double kMirrorSeparationSigmas =
    6.0;  // a mirror pair the guess tells apart: 3σ on each side
inline constexpr double kMultilaterationSpreadFraction = 0.1;  // its std, as a fraction of the shortest range
// 3-D: a start's error along a weakly anchored turn of a group decays by only 0.995 per sweep (§9.9), so a
// multilateration must be five times as sure before it starts an agent.
inline constexpr double kMultilaterationSpreadFraction3d = 0.02;

/// 3-D: a mirror image that fits the ranges within this of the best place (χ², one degree of freedom at the
/// self-check's false alarm) is not ruled out: neighbours' means can lag their covariances by many σ
/// (docs/algorithms.md §9.9).
inline double mirror_gap() { return chi_square_upper_quantile(1.0, kSelfCheckFalseAlarm); }

/// 3-D: the guess allows a place within this many of its variances in squared distance (χ², three degrees of
/// freedom at the self-check's false alarm).
inline double guess_allowance() { return chi_square_upper_quantile(3.0, kSelfCheckFalseAlarm); }

}  // namespace swarmloc::estimators::dml_thresholds
