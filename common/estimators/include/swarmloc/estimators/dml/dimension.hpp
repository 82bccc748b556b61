#pragma once
// dml in D = 2 or 3 dimensions (docs/algorithms.md §9.9): the position and covariance types, and where a D-
// dimensional position meets the messages. A 3-D position travels as its planar part plus an Altitude
// (core/altitude.hpp); D = 2 reads and writes the planar fields only, exactly as before.
#include <Eigen/Eigenvalues>
#include <cmath>
#include <optional>
#include <type_traits>
#include <utility>

#include "swarmloc/core/altitude.hpp"
#include "swarmloc/core/gaussian.hpp"
#include "swarmloc/core/types.hpp"
#include "swarmloc/estimators/kalman/kernels.hpp"
#include "swarmloc/estimators/messages.hpp"

namespace swarmloc::estimators {

template <int D>
using VecD = Eigen::Matrix<double, D, 1>;
template <int D>
using MatD = Eigen::Matrix<double, D, D>;

namespace dml_dimension {

static_assert(std::is_same_v<VecD<2>, Vec2> && std::is_same_v<MatD<2>, Mat2>);

/// The planar part (x, y).
template <int D>
Vec2 planar(const VecD<D>& x) {
  if constexpr (D == 2) {
    return x;
  } else {
    return x.template head<2>();
  }
}

/// The planar block of a covariance.
template <int D>
Mat2 planar(const MatD<D>& m) {
  if constexpr (D == 2) {
    return m;
  } else {
    return m.template topLeftCorner<2, 2>();
  }
}

/// A start position from the planar guess and its altitude.
template <int D>
VecD<D> position(const Vec2& planar_m, double z_m) {
  if constexpr (D == 2) {
    return planar_m;
  } else {
    return join(planar_m, z_m);
  }
}

/// Finite, symmetric and PD with its smallest eigenvalue above 1e−13 of its largest (D = 2: the 2-D test
/// every estimator uses, det > 1e−13·tr²).
template <int D>
bool positive_definite_d(const MatD<D>& m) {
  if constexpr (D == 2) {
    return positive_definite(m);
  } else {
    constexpr double kMinEigenvalueRatio = 1e-13;
    if (!m.allFinite()) return false;
    const double scale = m.cwiseAbs().maxCoeff();
    if (!((m - m.transpose()).cwiseAbs().maxCoeff() <= 1e-9 * scale)) return false;
    const Eigen::SelfAdjointEigenSolver<MatD<D>> eigen(m, Eigen::EigenvaluesOnly);
    const double largest = eigen.eigenvalues()(D - 1);
    return largest > 0.0 && eigen.eigenvalues()(0) > kMinEigenvalueRatio * largest;
  }
}

template <int D>
MatD<D> symmetrized_d(const MatD<D>& m) {
  if constexpr (D == 2) {
    return core::symmetrized(m);
  } else {
    return 0.5 * (m + m.transpose());
  }
}

/// A neighbour's published position and covariance. Nothing if a 3-D agent cannot use it (no altitude).
template <int D>
std::optional<std::pair<VecD<D>, MatD<D>>> read_state(const StateMessage& state) {
  if constexpr (D == 2) {
    return std::pair{state.mean_m, state.covariance};
  } else {
    if (!state.altitude) return std::nullopt;
    return std::pair{join(state.mean_m, state.altitude->z_m), join(state.covariance, *state.altitude)};
  }
}

/// Writes a position and covariance into a state (D = 3: with its altitude).
template <int D>
void write_state(const VecD<D>& mean_m, const MatD<D>& covariance, StateMessage& state) {
  state.mean_m = planar<D>(mean_m);
  state.covariance = planar<D>(covariance);
  if constexpr (D == 3) state.altitude = altitude_of(mean_m, covariance);
}

template <int D>
void write_estimate(const VecD<D>& mean_m, const MatD<D>& covariance, Estimate& estimate) {
  estimate.mean_m = planar<D>(mean_m);
  estimate.covariance = planar<D>(covariance);
  if constexpr (D == 3) estimate.altitude = altitude_of(mean_m, covariance);
}

/// The peer's position an edge summary carries.
template <int D>
VecD<D> peer_position(const EdgeRangeSummary& summary) {
  if constexpr (D == 2) {
    return summary.peer_mean_m;
  } else {
    return join(summary.peer_mean_m, summary.peer_z_m);
  }
}

/// An edge summary about `peer` with its position `peer_mean_m` (D = 2: peer_z_m stays 0).
template <int D>
EdgeRangeSummary summary(AgentId peer, double information, double mean_range_m, const VecD<D>& peer_mean_m) {
  EdgeRangeSummary out{peer, information, mean_range_m, planar<D>(peer_mean_m)};
  if constexpr (D == 3) out.peer_z_m = peer_mean_m.z();
  return out;
}

}  // namespace dml_dimension
}  // namespace swarmloc::estimators
