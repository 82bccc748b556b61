#include "swarmloc/estimators/dml/region.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "dml/rank_one_message.hpp"
#include "swarmloc/core/gaussian.hpp"
#include "swarmloc/estimators/kalman/kernels.hpp"

namespace swarmloc::estimators::region {
namespace {

using rank_one::kShortestDistanceM;

/// The message s·aaᵀ into an end whose belief has precision `own` along a, from an end with `other`, at
/// belief propagation's fixed point on the range (information w): with the cavities κ = own − s and
/// κ' = other − s', s = wκ'/(w + κ') and s' = wκ/(w + κ) reduce to y² + own·y = w²·own/other for
/// y = w − s. Clamped to [0, w]: beliefs that are not such a fixed point (stale ones) still give a message.
double fixed_point_message(double own, double other, double w) {
  const double y = 0.5 * (std::sqrt(own * own + 4.0 * w * w * own / other) - own);
  return std::clamp(w - y, 0.0, w);
}

/// The rank-one messages the two ends of a range put into each other's beliefs (docs/algorithms.md §9.3).
template <int D>
std::pair<double, double> link_messages(const MatD<D>& first_covariance, const MatD<D>& second_covariance,
                                        const VecD<D>& a, double information) {
  const double first = 1.0 / a.dot(first_covariance * a);  // belief precisions along a
  const double second = 1.0 / a.dot(second_covariance * a);
  return {fixed_point_message(first, second, information), fixed_point_message(second, first, information)};
}

/// The information of a range between variables `p` and `q` (D×D blocks at Dp, Dq) along `a`.
template <int D>
void add_range(MatX& information, Eigen::Index p, Eigen::Index q, const VecD<D>& a, double weight) {
  const MatD<D> block = weight * a * a.transpose();
  information.block<D, D>(D * p, D * p) += block;
  information.block<D, D>(D * q, D * q) += block;
  information.block<D, D>(D * p, D * q) -= block;
  information.block<D, D>(D * q, D * p) -= block;
}

/// `m` with negative eigenvalues set to zero: what is left of a belief after its inside messages are
/// taken out is information, never less than none.
template <int D>
MatD<D> clamped_to_psd(const MatD<D>& m) {
  Eigen::SelfAdjointEigenSolver<MatD<D>> eigen;
  if constexpr (D == 2) {
    if (m.trace() >= 0.0 && m.determinant() >= 0.0) return m;  // both eigenvalues ≥ 0
    eigen.computeDirect(core::symmetrized(m));
  } else {
    eigen.compute(dml_dimension::symmetrized_d<D>(m));
    if (eigen.eigenvalues()(0) >= 0.0) return m;
  }
  const VecD<D> values = eigen.eigenvalues().cwiseMax(0.0);
  return eigen.eigenvectors() * values.asDiagonal() * eigen.eigenvectors().transpose();
}

/// A member with a belief (not the placeholder of one without, whose messages are nil) and a range to
/// linearize along.
template <int D>
bool usable(const MemberT<D>& member, const VecD<D>& centre_m) {
  return member.information > 0.0 && member.mean_m.allFinite() &&
         dml_dimension::positive_definite_d<D>(member.covariance) &&
         member.covariance.trace() < kUndefinedVarianceM2 &&
         (centre_m - member.mean_m).norm() >= kShortestDistanceM;
}

}  // namespace

template <int D>
std::optional<MatD<D>> centre_covariance(const std::type_identity_t<VecD<D>>& centre_m,
                                         const std::type_identity_t<MatD<D>>& prior_information,
                                         const std::vector<MemberT<D>>& members,
                                         const std::vector<Link>& links,
                                         const std::vector<KnownT<D>>& known) {
  // Variable 0 is the centre; usable members follow in order.
  std::vector<Eigen::Index> slot(members.size(), -1);
  Eigen::Index size = 1;
  for (std::size_t k = 0; k < members.size(); ++k)
    if (usable<D>(members[k], centre_m)) slot[k] = size++;
  MatX information = MatX::Zero(D * size, D * size);
  information.topLeftCorner<D, D>() = prior_information;
  for (const auto& anchor : known) {
    const VecD<D> offset = centre_m - anchor.mean_m;
    if (offset.norm() < kShortestDistanceM) continue;
    const VecD<D> a = offset.normalized();
    information.topLeftCorner<D, D>() += anchor.information * a * a.transpose();
  }
  std::vector<MatD<D>> outside(members.size(), MatD<D>::Zero());
  for (std::size_t k = 0; k < members.size(); ++k) {
    if (slot[k] < 0) continue;
    const MemberT<D>& member = members[k];
    const VecD<D> a = (centre_m - member.mean_m).normalized();
    outside[k] = member.covariance.inverse() - member.sent_scale * a * a.transpose();
    add_range<D>(information, 0, slot[k], a, member.information);
  }
  std::vector<std::size_t> inside_links(members.size(), 0);  // its links to other members
  for (const auto& link : links) {
    const MemberT<D>& first = members[link.first];
    const MemberT<D>& second = members[link.second];
    const VecD<D> offset = first.mean_m - second.mean_m;
    if (slot[link.first] < 0 || slot[link.second] < 0 || !(link.information > 0.0) ||
        offset.norm() < kShortestDistanceM)
      continue;
    const VecD<D> a = offset.normalized();
    const auto [to_first, to_second] =
        link_messages<D>(first.covariance, second.covariance, a, link.information);
    outside[link.first] -= to_first * a * a.transpose();
    outside[link.second] -= to_second * a * a.transpose();
    add_range<D>(information, slot[link.first], slot[link.second], a, link.information);
    ++inside_links[link.first];
    ++inside_links[link.second];
  }
  // A member every one of whose neighbours is in the neighbourhood gets nothing from outside it: what its
  // belief holds beyond the messages taken out is loops counted again.
  for (std::size_t k = 0; k < members.size(); ++k) {
    if (slot[k] < 0) continue;
    const bool closed = members[k].degree > 0 && members[k].degree == 1 + inside_links[k];
    if (!closed) information.block<D, D>(D * slot[k], D * slot[k]) += clamped_to_psd<D>(outside[k]);
  }
  const Eigen::LLT<MatX> factor(information);
  if (factor.info() != Eigen::Success) return std::nullopt;
  const MatX columns = factor.solve(MatX::Identity(D * size, D));
  const MatD<D> covariance = dml_dimension::symmetrized_d<D>(columns.topRows<D>());
  if (!covariance.allFinite() || !dml_dimension::positive_definite_d<D>(covariance)) return std::nullopt;
  return covariance;
}

template std::optional<Mat2> centre_covariance(const Vec2&, const Mat2&, const std::vector<MemberT<2>>&,
                                               const std::vector<Link>&, const std::vector<KnownT<2>>&);
template std::optional<Mat3> centre_covariance(const Vec3&, const Mat3&, const std::vector<MemberT<3>>&,
                                               const std::vector<Link>&, const std::vector<KnownT<3>>&);

}  // namespace swarmloc::estimators::region
