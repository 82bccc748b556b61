// `swarmloc-research reproduce <experiment>`: the experiments by name. Each paper's experiments are in
// reproduce_0NN.cpp; the papers' reference numbers in research/data/reference/*.csv.
#include "reproduce.hpp"

#include <cstdio>
#include <functional>
#include <map>

#include "reproduce_common.hpp"

namespace swarmloc::research {
namespace {

using Experiment = std::function<int(const ReproduceOptions&)>;

/// Name → experiment, in the order `known_experiments()` lists them.
const std::vector<std::pair<std::string, Experiment>>& experiments() {
  using namespace reproduce_detail;
  static const std::vector<std::pair<std::string, Experiment>> table{
      {"ea1", reproduce_ea1},
      {"ea2", reproduce_ea2},
      {"ea3", reproduce_ea3},
      {"ieif-table1",
       [](const ReproduceOptions& options) {
         return reproduce_kalman_table(options, "ieif_table1", "001_table1",
                                       "Gasparri & Pascucci Table I — IEIF vs IEKF, 90 nodes, 30 anchors, "
                                       "noise std 0.05 / 0.2 / 0.5 m");
       }},
      {"ieif-table2",
       [](const ReproduceOptions& options) {
         return reproduce_kalman_table(options, "ieif_table2", "001_table2",
                                       "Gasparri & Pascucci Table II — IEIF vs IEKF, noise std 0.1 m, "
                                       "node/anchor ratio 4, 30 m × 30 m");
       }},
      {"jacobi-002", reproduce_jacobi},
      {"joint-field-002", reproduce_joint_field},
      {"tracking-002", reproduce_tracking},
      {"multipath-003", reproduce_multipath},
      {"dgbb-004-table1", reproduce_dgbb_table1},
      {"dgbb-004-figs", reproduce_dgbb_figures},
      {"dgbb-004-table2", reproduce_dgbb_table2},
      {"dgbb-004-table3", reproduce_dgbb_table3},
  };
  return table;
}

}  // namespace

const std::vector<std::string>& known_experiments() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const auto& [name, experiment] : experiments()) out.push_back(name);
    return out;
  }();
  return names;
}

int run_reproduce(const ReproduceOptions& options) {
  for (const auto& [name, experiment] : experiments()) {
    if (name == options.experiment) return experiment(options);
  }
  std::string known;
  for (const auto& name : known_experiments()) known += (known.empty() ? "" : ", ") + name;
  std::fprintf(stderr, "error: unknown experiment '%s' (known: %s)\n", options.experiment.c_str(),
               known.c_str());
  return 2;
}

}  // namespace swarmloc::research
