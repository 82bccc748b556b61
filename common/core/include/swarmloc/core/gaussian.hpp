#pragma once
// Checks and conversions for small Gaussians (moments <-> information).
#include "swarmloc/core/types.hpp"

namespace swarmloc::core {

/// True if every entry is finite.
bool all_finite(const Eigen::Ref<const MatX>& m);

/// Symmetric within `tolerance` (relative to the largest entry) and eigenvalues >= -tolerance·scale.
bool is_symmetric_psd(const Mat2& m, double tolerance = 1e-9);
/// The same for a square matrix of any size (a non-square one is not).
bool is_symmetric_psd_dynamic(const MatX& m, double tolerance = 1e-9);

/// Symmetric and strictly positive definite (LLT succeeds).
bool is_symmetric_pd(const Mat2& m, double tolerance = 1e-9);

/// (m + mᵀ)/2.
inline Mat2 symmetrized(const Mat2& m) { return 0.5 * (m + m.transpose()); }

}  // namespace swarmloc::core
