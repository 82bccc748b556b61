#pragma once
// The covariance dml reports (docs/algorithms.md §9.3, "Region correction"): loopy belief propagation
// counts the information that goes round a loop more than once, so an agent solves its neighbourhood
// exactly instead: itself, its neighbours, the ranges between them, and each neighbour's information from
// outside the neighbourhood (its belief without the messages from inside).
#include <cstddef>
#include <optional>
#include <vector>

#include "swarmloc/core/types.hpp"

namespace swarmloc::estimators::region {

/// A neighbour with a belief of its own.
struct Member {
  Vec2 mean_m;
  Mat2 covariance;     // its published (belief propagation) covariance
  double information;  // of the range between it and the centre
  double sent_scale;   // the message s·aaᵀ the centre sent it
  /// Its neighbours in all (its published degree), 0 if not known: when they are the centre and members it
  /// has links to, it has no information from outside the neighbourhood.
  std::size_t degree = 0;
};
/// A range between two members (indices into the members).
struct Link {
  std::size_t first;
  std::size_t second;
  double information;
};
/// A neighbour whose position is known exactly (an anchor): its range only informs the centre.
struct Known {
  Vec2 mean_m;
  double information;
};

/// The centre's marginal covariance in the neighbourhood's Gaussian (ranges linearized at the means), or
/// nothing if that Gaussian does not fix the centre.
std::optional<Mat2> centre_covariance(const Vec2& centre_m, const Mat2& prior_information,
                                      const std::vector<Member>& members, const std::vector<Link>& links,
                                      const std::vector<Known>& known);

}  // namespace swarmloc::estimators::region
