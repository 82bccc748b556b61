#include "swarmloc/estimators/crlb.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>

#include "swarmloc/models/measurement_models.hpp"

namespace swarmloc::estimators {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

template <int D>
using CrlbVec = Eigen::Matrix<double, D, 1>;
template <int D>
using CrlbMat = Eigen::Matrix<double, D, D>;

/// Column offset of each agent in θ, −1 for anchors.
template <int D>
std::vector<Eigen::Index> unknown_offsets(const RangeNetworkOf<D>& network) {
  std::vector<Eigen::Index> offset(network.truth.size(), -1);
  Eigen::Index next = 0;
  for (std::size_t i = 0; i < network.truth.size(); ++i) {
    if (!network.is_anchor[i]) {
      offset[i] = next;
      next += D;
    }
  }
  return offset;
}

/// ∂‖x_a − x_b‖/∂x_a, the unit vector from b to a; nullopt for (nearly) coincident points (§1.1).
template <int D>
std::optional<CrlbVec<D>> crlb_range_direction(const CrlbVec<D>& xa, const CrlbVec<D>& xb) {
  if constexpr (D == 2) {
    const auto h = models::range(xa, xb);
    if (!h) return std::nullopt;
    return Vec2(h->d_xi.transpose());
  } else {
    const CrlbVec<D> delta = xa - xb;
    const double rho = delta.norm();
    if (!(rho >= models::kMinDistanceM)) return std::nullopt;
    return CrlbVec<D>(delta / rho);
  }
}

void check_id(AgentId id, std::size_t n, const char* what) {
  if (id < 0 || static_cast<std::size_t>(id) >= n) {
    throw std::invalid_argument(std::string("crlb: ") + what + " id " + std::to_string(id) +
                                " is outside [0, " + std::to_string(n) + ")");
  }
}

template <int D>
MatX crlb_fisher_in(const RangeNetworkOf<D>& network, double snapshots,
                    const std::vector<CrlbMat<D>>* prior_information) {
  const std::size_t n = network.truth.size();
  if (network.is_anchor.size() != n) throw std::invalid_argument("crlb: is_anchor and truth differ in size");
  if (prior_information != nullptr && prior_information->size() != n) {
    throw std::invalid_argument("crlb: prior_information and truth differ in size");
  }
  if (!(snapshots >= 0.0)) throw std::invalid_argument("crlb: snapshots must be >= 0");
  const std::vector<Eigen::Index> offset = unknown_offsets(network);
  Eigen::Index dim = 0;
  for (const auto o : offset) dim += (o >= 0 ? D : 0);
  MatX J = MatX::Zero(dim, dim);

  // docs/algorithms.md §1.3, range: ±u uᵀ/s² into blocks (i,i), (j,j), (i,j), (j,i).
  for (const auto& obs : network.ranges) {
    check_id(obs.a, n, "range");
    check_id(obs.b, n, "range");
    if (!(obs.std_m > 0.0)) throw std::invalid_argument("crlb: range std_m must be > 0");
    const auto a = static_cast<std::size_t>(obs.a);
    const auto b = static_cast<std::size_t>(obs.b);
    const auto direction = crlb_range_direction<D>(network.truth[a], network.truth[b]);
    if (!direction) continue;  // coincident positions: no direction, no information
    const CrlbVec<D>& u = *direction;
    const CrlbMat<D> block = snapshots * u * u.transpose() / (obs.std_m * obs.std_m);
    const Eigen::Index oa = offset[a];
    const Eigen::Index ob = offset[b];
    if (oa >= 0) J.template block<D, D>(oa, oa) += block;
    if (ob >= 0) J.template block<D, D>(ob, ob) += block;
    if (oa >= 0 && ob >= 0) {
      J.template block<D, D>(oa, ob) -= block;
      J.template block<D, D>(ob, oa) -= block;
    }
  }
  // GPS/absolute: R⁻¹ into (i,i).
  for (const auto& obs : network.absolute) {
    check_id(obs.agent, n, "absolute");
    const Eigen::Index o = offset[static_cast<std::size_t>(obs.agent)];
    if (o < 0) continue;
    const Eigen::LLT<CrlbMat<D>> llt(obs.covariance);
    if (llt.info() != Eigen::Success) throw std::invalid_argument("crlb: absolute covariance must be PD");
    J.template block<D, D>(o, o) += snapshots * llt.solve(CrlbMat<D>::Identity());
  }
  if (prior_information != nullptr) {
    for (std::size_t i = 0; i < n; ++i) {
      if (offset[i] >= 0) J.template block<D, D>(offset[i], offset[i]) += (*prior_information)[i];
    }
  }
  return J;
}

template <int D>
CrlbResultOf<D> crlb_in(const RangeNetworkOf<D>& network, double snapshots,
                        const std::vector<CrlbMat<D>>* prior_information) {
  const MatX J = crlb_fisher_in<D>(network, snapshots, prior_information);
  const std::vector<Eigen::Index> offset = unknown_offsets(network);
  const std::size_t n = network.truth.size();
  const Eigen::Index dim = J.rows();

  CrlbResultOf<D> result;
  result.per_agent.assign(n, CrlbMat<D>::Zero());
  result.per_agent_rmse_m.assign(n, 0.0);
  if (dim == 0) {
    result.network_rmse_m = 0.0;
    result.localizable = true;
    return result;
  }

  // Scale-free singularity threshold on the eigenvalues / Cholesky pivots of J.
  const double scale = J.diagonal().cwiseAbs().maxCoeff();
  const double tolerance = 1e-10 * std::max(scale, 1e-300);
  MatX crb;
  std::vector<bool> unbounded(n, false);
  const Eigen::LLT<MatX> llt(J);
  const bool well_posed = scale > 0.0 && llt.info() == Eigen::Success &&
                          llt.matrixLLT().diagonal().cwiseAbs2().minCoeff() > tolerance;
  if (well_posed) {
    crb = llt.solve(MatX::Identity(dim, dim));
  } else {
    // Singular J: agents with a component in the null space are not localizable (+inf); the rest
    // are identifiable and take their block of the pseudo-inverse (§1.3).
    const Eigen::SelfAdjointEigenSolver<MatX> eig(J);
    const VecX& lambda = eig.eigenvalues();
    const MatX& V = eig.eigenvectors();
    VecX inv_lambda = VecX::Zero(dim);
    for (Eigen::Index k = 0; k < dim; ++k) {
      if (lambda(k) > tolerance) {
        inv_lambda(k) = 1.0 / lambda(k);
        continue;
      }
      for (std::size_t i = 0; i < n; ++i) {
        if (offset[i] >= 0 && V.block(offset[i], k, D, 1).norm() > 1e-6) unbounded[i] = true;
      }
    }
    crb = V * inv_lambda.asDiagonal() * V.transpose();
  }

  double trace = 0.0;
  int unknowns = 0;
  result.localizable = true;
  for (std::size_t i = 0; i < n; ++i) {
    if (offset[i] < 0) continue;
    ++unknowns;
    if (unbounded[i]) {
      result.per_agent[i] = CrlbMat<D>::Constant(kInf);
      result.per_agent_rmse_m[i] = kInf;
      result.localizable = false;
      continue;
    }
    const CrlbMat<D> block = crb.template block<D, D>(offset[i], offset[i]);
    result.per_agent[i] = 0.5 * (block + block.transpose());
    result.per_agent_rmse_m[i] = std::sqrt(std::max(0.0, block.trace()));
    trace += block.trace();
  }
  result.network_rmse_m = result.localizable ? std::sqrt(std::max(0.0, trace) / unknowns) : kInf;
  return result;
}

}  // namespace

MatX range_network_fisher(const RangeNetwork& network, double snapshots,
                          const std::vector<Mat2>* prior_information) {
  return crlb_fisher_in<2>(network, snapshots, prior_information);
}

MatX range_network_fisher(const RangeNetwork3& network, double snapshots,
                          const std::vector<Mat3>* prior_information) {
  return crlb_fisher_in<3>(network, snapshots, prior_information);
}

CrlbResult network_crlb(const RangeNetwork& network, double snapshots,
                        const std::vector<Mat2>* prior_information) {
  return crlb_in<2>(network, snapshots, prior_information);
}

CrlbResult3 network_crlb(const RangeNetwork3& network, double snapshots,
                         const std::vector<Mat3>* prior_information) {
  return crlb_in<3>(network, snapshots, prior_information);
}

CrlbResult range_network_crlb(const std::vector<Vec2>& truth, const std::vector<bool>& is_anchor,
                              const std::vector<RangeObservation>& per_snapshot, double snapshots,
                              const std::vector<Mat2>* prior_information) {
  const RangeNetwork network{truth, is_anchor, per_snapshot, {}};
  return network_crlb(network, snapshots, prior_information);
}

std::vector<RangeObservation> mutual_range_observations(const std::vector<Vec2>& truth,
                                                        const std::vector<bool>& is_anchor, double std_m,
                                                        double radius_m) {
  std::vector<RangeObservation> out;
  const auto n = static_cast<AgentId>(truth.size());
  for (AgentId i = 0; i < n; ++i) {
    for (AgentId j = 0; j < n; ++j) {
      if (i == j) continue;
      const auto si = static_cast<std::size_t>(i);
      const auto sj = static_cast<std::size_t>(j);
      if (is_anchor[si] && is_anchor[sj]) continue;
      if ((truth[si] - truth[sj]).norm() <= radius_m) out.push_back(RangeObservation{i, j, std_m});
    }
  }
  return out;
}

}  // namespace swarmloc::estimators
