#pragma once
// The covariance dml reports (docs/algorithms.md §9.3, "Region correction"): loopy belief propagation
// counts the information that goes round a loop more than once, so an agent solves its neighbourhood
// exactly instead: itself, its neighbours, the ranges between them, and each neighbour's information from
// outside the neighbourhood (its belief without the messages from inside).
#include <cstddef>
#include <optional>
#include <type_traits>
#include <vector>

#include "swarmloc/estimators/dml/dimension.hpp"

namespace swarmloc::estimators::region {

/// A neighbour with a belief of its own.
template <int D>
struct MemberT {
  VecD<D> mean_m;
  MatD<D> covariance;  // its published (belief propagation) covariance
  double information;  // of the range between it and the centre
  double sent_scale;   // the message s·aaᵀ the centre sent it
  /// Its neighbours in all (its published degree), 0 if not known: when they are the centre and members it
  /// has links to, it has no information from outside the neighbourhood.
  std::size_t degree = 0;
};
using Member = MemberT<2>;
/// A range between two members (indices into the members).
struct Link {
  std::size_t first;
  std::size_t second;
  double information;
};
/// A neighbour whose position is known exactly (an anchor): its range only informs the centre.
template <int D>
struct KnownT {
  VecD<D> mean_m;
  double information;
};
using Known = KnownT<2>;

/// The centre's marginal covariance in the neighbourhood's Gaussian (ranges linearized at the means), or
/// nothing if that Gaussian does not fix the centre.
template <int D>
std::optional<MatD<D>> centre_covariance(const std::type_identity_t<VecD<D>>& centre_m,
                                         const std::type_identity_t<MatD<D>>& prior_information,
                                         const std::vector<MemberT<D>>& members,
                                         const std::vector<Link>& links, const std::vector<KnownT<D>>& known);

extern template std::optional<Mat2> centre_covariance(const Vec2&, const Mat2&,
                                                      const std::vector<MemberT<2>>&,
                                                      const std::vector<Link>&,
                                                      const std::vector<KnownT<2>>&);
extern template std::optional<Mat3> centre_covariance(const Vec3&, const Mat3&,
                                                      const std::vector<MemberT<3>>&,
                                                      const std::vector<Link>&,
                                                      const std::vector<KnownT<3>>&);

}  // namespace swarmloc::estimators::region
