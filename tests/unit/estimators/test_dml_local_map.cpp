// dml's local maps (docs/algorithms.md §9.4, "Local maps"): placing an agent from its neighbourhood's ranges
// where no single neighbour's ranges do.
#include <gtest/gtest.h>

#include <vector>

#include "swarmloc/estimators/dml/local_map.hpp"

namespace swarmloc::estimators::local_map {
namespace {

constexpr double kInformation = 100.0;  // σ = 0.1 m

/// Three agents to place (nodes 0–2), each ranging to two of three known agents and to each other: no one
/// of them is fixed by its own known neighbours, the three together are.
struct Pocket {
  std::vector<Vec2> truth{{6, 5}, {14, 5}, {10, 11}, {0, 0}, {20, 0}, {10, 17}};
  std::vector<std::pair<int, int>> links{{0, 3}, {0, 5}, {1, 4}, {1, 5}, {2, 3},
                                         {2, 4}, {0, 1}, {1, 2}, {0, 2}};

  [[nodiscard]] std::vector<Node> nodes(const std::vector<Vec2>& guesses) const {
    std::vector<Node> out;
    for (std::size_t i = 0; i < truth.size(); ++i)
      out.push_back(i < 3 ? Node{false, guesses[i]} : Node{true, truth[i]});
    return out;
  }
  [[nodiscard]] std::vector<Range> ranges() const {
    std::vector<Range> out;
    for (const auto& [a, b] : links)
      out.push_back({a, b, (truth[static_cast<std::size_t>(a)] - truth[static_cast<std::size_t>(b)]).norm(),
                     kInformation});
    return out;
  }
};

/// The guesses of the agents to place: far off, and on the wrong side of every pair of known agents.
std::vector<Vec2> bad_guesses() { return {{40, -30}, {-25, 40}, {10, -20}}; }

TEST(DmlLocalMap, PlacesAnAgentOfAPocketFromAnyGuess) {
  const Pocket pocket;
  const auto placement = place(pocket.nodes(bad_guesses()), pocket.ranges(), 1e-3, 1.0);
  ASSERT_TRUE(placement.has_value());
  EXPECT_LT((placement->position_m - pocket.truth[0]).norm(), 1e-6);
  EXPECT_FALSE(placement->alternative_m.has_value());
}

TEST(DmlLocalMap, RefusesAMapItsRangesContradict) {
  Pocket pocket;
  auto ranges = pocket.ranges();
  ranges[6].range_m += 2.0;  // 20 σ off: no map fits
  EXPECT_FALSE(place(pocket.nodes(bad_guesses()), ranges, 1e-3, 1.0).has_value());
}

TEST(DmlLocalMap, LeavesOutAnAgentHeldByTwoRanges) {
  // Node 0 keeps only its ranges to nodes 1 and 2: it could sit on either side of their line.
  Pocket pocket;
  pocket.links = {{0, 1}, {0, 2}, {1, 4}, {1, 5}, {1, 3}, {2, 3}, {2, 4}, {1, 2}};
  EXPECT_FALSE(place(pocket.nodes(bad_guesses()), pocket.ranges(), 1e-3, 1.0).has_value());
}

TEST(DmlLocalMap, GivesTheMirrorImageWhenTwoKnownAgentsHoldTheMap) {
  // Without the third known agent the map fits both ways round across the line through the other two.
  Pocket pocket;
  pocket.truth.pop_back();
  pocket.links = {{0, 3}, {1, 4}, {2, 3}, {2, 4}, {0, 1}, {1, 2}, {0, 2}};
  const auto placement = place(pocket.nodes(bad_guesses()), pocket.ranges(), 1e-3, 1.0);
  ASSERT_TRUE(placement.has_value());
  ASSERT_TRUE(placement->alternative_m.has_value());
  const Vec2 mirror(pocket.truth[0].x(), -pocket.truth[0].y());  // the known agents lie on the x axis
  const bool truth_first = (placement->position_m - pocket.truth[0]).norm() < 1e-6;
  EXPECT_LT(((truth_first ? *placement->alternative_m : placement->position_m) - mirror).norm(), 1e-6);
  EXPECT_LT(((truth_first ? placement->position_m : *placement->alternative_m) - pocket.truth[0]).norm(),
            1e-6);
}

TEST(DmlLocalMap, RefusesAPlaceLessCertainThanAsked) {
  const Pocket pocket;
  EXPECT_FALSE(place(pocket.nodes(bad_guesses()), pocket.ranges(), 1e-3, 1e-4).has_value());
}

/// Σ W aaᵀ over the ranges, over the coordinates of the first `unknowns` nodes (the others held).
MatX fisher_information(const std::vector<Vec2>& x, const std::vector<std::pair<int, int>>& links,
                        int unknowns) {
  MatX information = MatX::Zero(2 * unknowns, 2 * unknowns);
  for (const auto& [a, b] : links) {
    const Vec2 u = (x[static_cast<std::size_t>(a)] - x[static_cast<std::size_t>(b)]).normalized();
    const Mat2 block = kInformation * u * u.transpose();
    if (a < unknowns) information.block<2, 2>(2 * a, 2 * a) += block;
    if (b < unknowns) information.block<2, 2>(2 * b, 2 * b) += block;
    if (a < unknowns && b < unknowns) {
      information.block<2, 2>(2 * a, 2 * b) -= block;
      information.block<2, 2>(2 * b, 2 * a) -= block;
    }
  }
  return information;
}

TEST(DmlLocalMap, CovarianceIsTheInverseFisherInformationOfTheAgentsToPlace) {
  Pocket pocket;
  const Mat2 expected = fisher_information(pocket.truth, pocket.links, 3).inverse().topLeftCorner<2, 2>();
  // A fourth agent to place, held by one range to node 0 only: it turns freely about node 0 and tells no
  // one anything, so it changes nothing (it is left out, not a singular block).
  auto nodes = pocket.nodes({pocket.truth[0], pocket.truth[1], pocket.truth[2]});
  nodes.push_back({false, Vec2(3.0, 9.0)});
  auto ranges = pocket.ranges();
  ranges.push_back({0, 6, 5.0, kInformation});
  const auto covariance = covariance_at(nodes, ranges);
  ASSERT_TRUE(covariance.has_value());
  EXPECT_LT((*covariance - expected).norm(), 1e-9 * expected.norm());
}

TEST(DmlLocalMap, GivesNoCovarianceWhereTheMapTurnsAboutOneKnownAgent) {
  // Only node 3 known: the pocket, rigid in itself, can turn about it.
  Pocket pocket;
  pocket.links = {{0, 3}, {1, 3}, {2, 3}, {0, 1}, {1, 2}, {0, 2}};
  EXPECT_FALSE(
      covariance_at(pocket.nodes({pocket.truth[0], pocket.truth[1], pocket.truth[2]}), pocket.ranges())
          .has_value());
  pocket.links.emplace_back(2, 4);  // a second known agent stops the turn
  EXPECT_TRUE(
      covariance_at(pocket.nodes({pocket.truth[0], pocket.truth[1], pocket.truth[2]}), pocket.ranges())
          .has_value());
}

}  // namespace
}  // namespace swarmloc::estimators::local_map
