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
std::pair<double, double> link_messages(const Mat2& first_covariance, const Mat2& second_covariance,
                                        const Vec2& a, double information) {
  const double first = 1.0 / a.dot(first_covariance * a);  // belief precisions along a
  const double second = 1.0 / a.dot(second_covariance * a);
  return {fixed_point_message(first, second, information), fixed_point_message(second, first, information)};
}

/// The information of a range between variables `p` and `q` (2×2 blocks at 2p, 2q) along `a`.
void add_range(MatX& information, Eigen::Index p, Eigen::Index q, const Vec2& a, double weight) {
  const Mat2 block = weight * a * a.transpose();
  information.block<2, 2>(2 * p, 2 * p) += block;
  information.block<2, 2>(2 * q, 2 * q) += block;
  information.block<2, 2>(2 * p, 2 * q) -= block;
  information.block<2, 2>(2 * q, 2 * p) -= block;
}

/// `m` with negative eigenvalues set to zero: what is left of a belief after its inside messages are
/// taken out is information, never less than none.
Mat2 clamped_to_psd(const Mat2& m) {
  if (m.trace() >= 0.0 && m.determinant() >= 0.0) return m;
  Eigen::SelfAdjointEigenSolver<Mat2> eigen;
  eigen.computeDirect(core::symmetrized(m));
  const Vec2 values = eigen.eigenvalues().cwiseMax(0.0);
  return eigen.eigenvectors() * values.asDiagonal() * eigen.eigenvectors().transpose();
}

/// A member with a belief (not the placeholder of one without, whose messages are nil) and a range to
/// linearize along.
bool usable(const Member& member, const Vec2& centre_m) {
  return member.information > 0.0 && member.mean_m.allFinite() && positive_definite(member.covariance) &&
         member.covariance.trace() < kUndefinedVarianceM2 &&
         (centre_m - member.mean_m).norm() >= kShortestDistanceM;
}

}  // namespace

std::optional<Mat2> centre_covariance(const Vec2& centre_m, const Mat2& prior_information,
                                      const std::vector<Member>& members, const std::vector<Link>& links,
                                      const std::vector<Known>& known) {
  // Variable 0 is the centre; usable members follow in order.
  std::vector<Eigen::Index> slot(members.size(), -1);
  Eigen::Index size = 1;
  for (std::size_t k = 0; k < members.size(); ++k)
    if (usable(members[k], centre_m)) slot[k] = size++;
  MatX information = MatX::Zero(2 * size, 2 * size);
  information.topLeftCorner<2, 2>() = prior_information;
  for (const auto& anchor : known) {
    const Vec2 offset = centre_m - anchor.mean_m;
    if (offset.norm() < kShortestDistanceM) continue;
    const Vec2 a = offset.normalized();
    information.topLeftCorner<2, 2>() += anchor.information * a * a.transpose();
  }
  std::vector<Mat2> outside(members.size(), Mat2::Zero());
  for (std::size_t k = 0; k < members.size(); ++k) {
    if (slot[k] < 0) continue;
    const Member& member = members[k];
    const Vec2 a = (centre_m - member.mean_m).normalized();
    outside[k] = member.covariance.inverse() - member.sent_scale * a * a.transpose();
    add_range(information, 0, slot[k], a, member.information);
  }
  std::vector<std::size_t> inside_links(members.size(), 0);  // its links to other members
  for (const auto& link : links) {
    const Member& first = members[link.first];
    const Member& second = members[link.second];
    const Vec2 offset = first.mean_m - second.mean_m;
    if (slot[link.first] < 0 || slot[link.second] < 0 || !(link.information > 0.0) ||
        offset.norm() < kShortestDistanceM)
      continue;
    const Vec2 a = offset.normalized();
    const auto [to_first, to_second] =
        link_messages(first.covariance, second.covariance, a, link.information);
    outside[link.first] -= to_first * a * a.transpose();
    outside[link.second] -= to_second * a * a.transpose();
    add_range(information, slot[link.first], slot[link.second], a, link.information);
    ++inside_links[link.first];
    ++inside_links[link.second];
  }
  // A member every one of whose neighbours is in the neighbourhood gets nothing from outside it: what its
  // belief holds beyond the messages taken out is loops counted again.
  for (std::size_t k = 0; k < members.size(); ++k) {
    if (slot[k] < 0) continue;
    const bool closed = members[k].degree > 0 && members[k].degree == 1 + inside_links[k];
    if (!closed) information.block<2, 2>(2 * slot[k], 2 * slot[k]) += clamped_to_psd(outside[k]);
  }
  const Eigen::LLT<MatX> factor(information);
  if (factor.info() != Eigen::Success) return std::nullopt;
  const MatX columns = factor.solve(MatX::Identity(2 * size, 2));
  const Mat2 covariance = core::symmetrized(columns.topRows<2>());
  if (!covariance.allFinite() || !positive_definite(covariance)) return std::nullopt;
  return covariance;
}

}  // namespace swarmloc::estimators::region
