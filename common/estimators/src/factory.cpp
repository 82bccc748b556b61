// Algorithm registry behind make_estimator (estimator.hpp). To add an algorithm, add one row.
#include <array>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "swarmloc/estimators/dml.hpp"
#include "swarmloc/estimators/estimator.hpp"
#include "swarmloc/estimators/ieif.hpp"
#include "swarmloc/estimators/iekf.hpp"
#include "swarmloc/estimators/pose_filters.hpp"

namespace swarmloc::estimators {
namespace {

using Builder = std::unique_ptr<Estimator> (*)(const AgentSetup&, const KalmanFamilyParams&);

template <typename Algorithm>
std::unique_ptr<Estimator> build(const AgentSetup& setup, const KalmanFamilyParams& params) {
  return std::make_unique<Algorithm>(setup, params);
}

struct Registration {
  const char* name;
  Builder builder;
};

constexpr std::array kRegistry{
    Registration{"ieif", &build<Ieif>},                     // docs/algorithms.md §3.2
    Registration{"iekf", &build<Iekf>},                     // docs/algorithms.md §3.5
    Registration{"dml", &build<Dml>},                       // docs/algorithms.md §9
    Registration{"pose_ekf", &build<PoseEkf>},              // pose states (x, y, θ), pose_filters.hpp
    Registration{"pose_ieif", &build<PoseIeif>},            // its information form
    Registration{"dead_reckoning", &build<DeadReckoning>},  // odometry only (baseline)
};

}  // namespace

const std::vector<std::string>& known_algorithms() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const auto& entry : kRegistry) out.emplace_back(entry.name);
    return out;
  }();
  return names;
}

std::unique_ptr<Estimator> make_estimator(const std::string& algorithm, const AgentSetup& setup,
                                          const KalmanFamilyParams& params) {
  for (const auto& entry : kRegistry) {
    if (algorithm == entry.name) return entry.builder(setup, params);
  }
  std::string known;
  for (const auto& name : known_algorithms()) known += (known.empty() ? "" : ", ") + name;
  throw std::invalid_argument("estimator algorithm '" + algorithm + "' is unknown; known: " + known);
}

}  // namespace swarmloc::estimators
