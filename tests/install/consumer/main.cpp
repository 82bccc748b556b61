// Uses the installed estimators: the range CRLB of one agent at the centre of three anchors 120° apart
// (J = 3/(2σ²)·I, so the RMSE bound is 2σ/√3) and an IEIF from its builder. Exit 0 only if both hold.
#include <cmath>
#include <cstdio>
#include <numbers>

#include "swarmloc/estimators/builders.hpp"
#include "swarmloc/estimators/crlb.hpp"

int main() {
  using namespace swarmloc;
  constexpr double kStdM = 0.1;
  std::vector<Vec2> truth{Vec2::Zero()};
  std::vector<bool> is_anchor{false};
  std::vector<estimators::RangeObservation> ranges;
  for (int k = 0; k < 3; ++k) {
    const double angle = 2.0 * std::numbers::pi * k / 3.0;
    truth.emplace_back(std::cos(angle), std::sin(angle));
    is_anchor.push_back(true);
    ranges.push_back({0, static_cast<AgentId>(k + 1), kStdM});
  }
  const auto bound = estimators::range_network_crlb(truth, is_anchor, ranges);
  const double expected = 2.0 * kStdM / std::sqrt(3.0);
  estimators::AgentSetup setup;
  const auto filter = estimators::builders::ieif(setup, estimators::EstimatorParams{});
  std::printf("crlb %.12f expected %.12f estimator %s\n", bound.network_rmse_m, expected,
              std::string(filter->name()).c_str());
  return std::abs(bound.network_rmse_m - expected) < 1e-12 && filter->name() == "ieif" ? 0 : 1;
}
