#pragma once
// The consensus half of a DLE step (Atanasov et al. Algorithm 1, docs/algorithms.md §4.2, §4.5), shared by
// the DLE and the joint localization + field estimator. Internal to the estimators library.
#include <cstdint>
#include <functional>

#include "swarmloc/estimators/consensus/metropolis.hpp"
#include "swarmloc/estimators/estimator.hpp"

namespace swarmloc::estimators::consensus::detail {

/// Σ_{j∈N_i∪{i}} κ_ij (ω_j, Ω_j) over the own prior and the neighbour priors of `target` in the inbox.
/// κ are Metropolis weights; the own degree is |batch.neighbours| if given, else the number of neighbours
/// heard from. The κ of missing or malformed priors (wrong size, non-finite) are dropped and the rest
/// renormalized with self (§4.5); malformed ones count as skipped in `diagnostics`.
struct CombinedPrior {
  VecX omega;
  MatX Omega;
};
/// The estimate of a sensor whose position is known exactly (the DLE's sensors, the joint estimator's
/// true-position baseline).
Estimate known_position_estimate(const Vec2& position_m);

/// Brings a copy of a neighbour's well-formed prior to the receiver's time, in place (the tracking DLE);
/// false drops it (counted as skipped, its κ dropped as for a missing one).
using AlignPrior = std::function<bool(InformationMessage& prior)>;

CombinedPrior combine_priors(const VecX& omega, const MatX& Omega, std::int32_t target,
                             const StepInput& input, MetropolisRule rule, ConsensusDegrees& degrees,
                             StepDiagnostics& diagnostics, const AlignPrior& align = nullptr);

}  // namespace swarmloc::estimators::consensus::detail
