#pragma once
// Z = BandInv_L(A): the L-banded matrix whose inverse agrees with A on the band |i − j| <= L
// (the maximum-determinant completion). Khan et al. Alg. 1; docs/algorithms.md §2.3.
#include "swarmloc/estimators/centralized/band_matrix.hpp"

namespace swarmloc::estimators::centralized {

enum class BandInversionMethod {
  kWindows,         ///< Khan et al. Alg. 1 as listed: (L+1)×(L+1) and L×L window inverses, O(nL³)
  kSlidingCholesky  ///< same output via a sliding window Cholesky factor, O(nL²)
};

/// Khan et al. Alg. 1 with the window sizes. Reads only entries of `a` with |i − j| <= L (entries of
/// `a` outside its own band are zero). Returns Z in band storage of bandwidth L.
/// Throws std::invalid_argument for L outside [0, n−1], std::domain_error if a window is not PD.
BandMatrix band_inverse_windows(const BandMatrix& a, int bandwidth);

/// Same Z in O(nL²): Z = (I − B)ᵀ D⁻¹ (I − B), where row i of B regresses variable i on the L
/// variables before it (the order-L Gauss–Markov factor of the max-determinant completion). The
/// window Cholesky factor slides by one rank-1 update per row.
BandMatrix band_inverse_sliding(const BandMatrix& a, int bandwidth);

/// Dispatch on `method`.
BandMatrix band_inverse(const BandMatrix& a, int bandwidth, BandInversionMethod method);

/// Dense convenience: BandInv_L of a dense symmetric matrix (only its band is read).
MatX band_inverse(const MatX& a, int bandwidth, BandInversionMethod method = BandInversionMethod::kWindows);

}  // namespace swarmloc::estimators::centralized
