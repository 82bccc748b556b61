#pragma once
// The bound every run is scored against (docs/algorithms.md §1.3.1): for static truth the accumulated CRLB
// of the data the algorithm receives, for moving truth the posterior CRB along the true trajectory with
// the world's process noise, or no bound with the reason. Beside it, the bound of all the data.
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "swarmloc/config/algorithms.hpp"
#include "swarmloc/config/scenario.hpp"
#include "swarmloc/estimators/crlb.hpp"
#include "swarmloc/world/metrics.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::world {

/// Which range draws, what anchor data and which bound model: declared per algorithm in the registry
/// (config/algorithms.hpp).
using RangeDraws = config::RangeDraws;
using AnchorData = config::AnchorData;
using BoundModel = config::BoundModel;

/// The declared data of one algorithm: its registry entry's BoundSpec, named.
struct BoundData {
  std::string_view algorithm;
  BoundModel model = BoundModel::kNone;
  RangeDraws draws = RangeDraws::kAllDraws;
  AnchorData anchors = AnchorData::kKnown;
  std::string_view none_reason;  ///< model kNone: why
};

/// The row of `algorithm`; an algorithm without a row gets model kNone ("no bound data declared").
BoundData bound_data(const std::string& algorithm);
/// Every row of the table (tests check it covers every algorithm).
const std::vector<BoundData>& bound_data_table();

enum class BoundKind { kCrlbStaticAccumulated, kPcrb, kNone };
std::string_view to_string(BoundKind kind);
std::string_view to_string(RangeDraws draws);
std::string_view to_string(AnchorData anchors);

/// The run's bound, per world step (the bound of world steps 0 … k, in the order the runners score them).
struct RunBound {
  BoundKind kind = BoundKind::kNone;
  RangeDraws draws = RangeDraws::kAllDraws;
  AnchorData anchors = AnchorData::kKnown;
  std::string reason;  ///< kind kNone: why there is no bound
  /// Static truth: the single-snapshot network RMSE bounds (the step series is single / √(k + 1), or
  /// single throughout with noise.draw = once).
  double single_rmse_m = std::numeric_limits<double>::quiet_NaN();
  double all_data_single_rmse_m = std::numeric_limits<double>::quiet_NaN();
  bool fresh_draws_per_step = true;
  /// PCRB: the series itself (one entry per world step).
  std::vector<double> pcrb_rmse_m;
  std::vector<double> all_data_pcrb_rmse_m;

  /// The bound of world step `step` (NaN for kNone).
  [[nodiscard]] double rmse_at(std::int64_t step) const;
  [[nodiscard]] double all_data_rmse_at(std::int64_t step) const;
};

/// The bound of `world` (at world step 0, before any advance_truth) for `scenario`. `legacy` is
/// scenario_crlb's result for the same world (reused where it is the same bound). Moving truth is
/// replayed on a copy of the world (advance_truth is seeded, so it is the trajectory the run sees).
RunBound run_bound(const World& world, const config::Scenario& scenario, const RangeCrlb& legacy);

/// Whether the scenario's truth moves (a random walk with a nonzero step): its bound is then the PCRB and
/// its optimum a smoother.
[[nodiscard]] bool truth_moves(const config::Scenario& scenario);

/// The per-axis variance of the world's initial guesses (noisy_truth: initial_guess_std_m², floored so an
/// exact start keeps a finite prior; uniform: the placement's area_m²/12).
[[nodiscard]] double start_prior_variance(const config::Scenario& scenario);

// ---- The pieces, exposed for the tests ----

/// One world step's measurement information as a RangeNetwork at the positions `truth`: the ranges of
/// every step-0 edge still within world.comm_radius_m (as generate_batch measures them), selected by
/// `draws`, and the anchors' fixes if `anchors` is kFixes with noise.anchor_fix_std_m > 0 (else anchors
/// are known and leave θ).
estimators::RangeNetwork snapshot_network(const World& world, const config::Scenario& scenario,
                                          const std::vector<Vec2>& truth, RangeDraws draws,
                                          AnchorData anchors);

/// snapshot_network in space (a 3-D world, World::dimensions == 3): `truth` holds each agent's (x, y, z),
/// the ranges are 3-D distances, an anchor's fixes have covariance anchor_fix_std_m² I₃.
estimators::RangeNetwork3 snapshot_network3(const World& world, const config::Scenario& scenario,
                                            const std::vector<Vec3>& truth, RangeDraws draws,
                                            AnchorData anchors);

/// Every agent's true (x, y, z) (World::position3).
std::vector<Vec3> true_positions3(const World& world);

/// sqrt(mean over the world's non-anchor agents of tr([J⁻¹]_ii)) for a Fisher matrix over the network's
/// unknowns (anchors in θ are in J but not in the mean); +inf if J is singular.
double non_anchor_rmse(const MatX& covariance, const estimators::RangeNetwork& network,
                       const std::vector<bool>& world_anchor);

/// One PCRB prediction (docs/algorithms.md §1.3, random walk): (J⁻¹ + diag(q))⁻¹, q the per-coordinate
/// process variance of each state entry.
MatX pcrb_predict(const MatX& information, const VecX& process_variance);

}  // namespace swarmloc::world
