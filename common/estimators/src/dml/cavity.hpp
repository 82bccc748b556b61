#pragma once
// The cavity of dml's rank-one belief propagation messages (docs/algorithms.md §9.3).

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>

#include "dml/rank_one_message.hpp"
#include "swarmloc/estimators/dml/dimension.hpp"

namespace swarmloc::estimators::dml_cavity {

// s·q beyond this: the neighbour's belief lacks the message
inline constexpr double kMessageAbsentRatio = 2.0;
inline constexpr double kNoVariance = std::numeric_limits<double>::infinity();
using rank_one::kCavityTolerance;

/// A belief along unit vector `a` and the rank-one message s·aaᵀ it holds: q = aᵀPa, and 1 − s·q, the share
/// of the belief's information along `a` that is not the message (Sherman–Morrison).
struct AlongEdge {
  double variance = kNoVariance;
  double remaining = 0.0;
};

template <int D>
AlongEdge along_edge(const MatD<D>& covariance, const VecD<D>& a, double message_scale) {
  const double q = a.dot(covariance * a);
  return {q, 1.0 - message_scale * q};
}

/// a^T P a for the variance of position `covariance` along unit vector `a`, after the rank-one message
/// s·aaᵀ is taken out of its information: q / (1 − s q), +inf if nothing is left.
template <int D>
double cavity_variance(const MatD<D>& covariance, const VecD<D>& a, double message_scale) {
  const AlongEdge along = along_edge<D>(covariance, a, message_scale);
  if (!std::isfinite(along.variance)) return kNoVariance;
  return along.remaining > kCavityTolerance ? along.variance / along.remaining : kNoVariance;
}

/// The neighbour's variance along `a` without the message this agent sent it (`sent_scale`, or the one of the
/// step before, `previous_sent_scale`, which the neighbour's last belief may hold instead). A belief that
/// holds s·aaᵀ has s·q < 1 (Sherman–Morrison); well above 1 for both, the neighbour formed its belief without
/// either (it heard this agent while this agent's belief was undefined): nothing is there to take out
/// (docs/algorithms.md §9.3).
template <int D>
double far_cavity_variance(const MatD<D>& covariance, const VecD<D>& a, double sent_scale,
                           double previous_sent_scale) {
  const double q = a.dot(covariance * a);
  if (!std::isfinite(q)) return kNoVariance;
  for (const double scale : {sent_scale, previous_sent_scale}) {
    const double remaining = 1.0 - scale * q;
    if (remaining > kCavityTolerance) return q / remaining;
  }
  if (std::min(sent_scale, previous_sent_scale) * q > kMessageAbsentRatio) return q;
  return kNoVariance;
}

}  // namespace swarmloc::estimators::dml_cavity
