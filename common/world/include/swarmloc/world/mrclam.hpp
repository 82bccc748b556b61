#pragma once
// UTIAS Multi-Robot Cooperative Localization and Mapping dataset (Leung et al., IJRR 2011) as a
// recorded world: five robots become five agents, the fifteen landmarks known-position targets,
// odometry drives the unicycle model and the range-bearing measurements are delivered in the world
// step that contains their timestamp. The data is read from the user's directory (plain .dat or
// gzip-compressed .dat.gz files), never shipped with the project.
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <vector>

#include "swarmloc/config/scenario.hpp"
#include "swarmloc/world/world.hpp"

namespace swarmloc::world {

struct MrclamDataset {
  struct TimedPose {
    double time_s = 0.0;
    Vec2 position_m = Vec2::Zero();
    double heading_rad = 0.0;
  };
  struct OdometryRow {
    double time_s = 0.0;
    double v_mps = 0.0;
    double omega_radps = 0.0;
  };
  struct MeasurementRow {
    double time_s = 0.0;
    int subject = 0;  ///< 1–5 robots, 6–20 landmarks (barcodes already mapped)
    double range_m = 0.0;
    double bearing_rad = 0.0;
  };
  struct Robot {
    std::vector<TimedPose> groundtruth;
    std::vector<OdometryRow> odometry;
    std::vector<MeasurementRow> measurements;
  };
  struct Landmark {
    Vec2 position_m = Vec2::Zero();
    Vec2 std_m = Vec2::Zero();
  };

  std::vector<Robot> robots;          ///< robots[i] = subject i + 1
  std::map<int, Landmark> landmarks;  ///< by subject number
  int unknown_barcodes = 0;           ///< measurement rows whose barcode is in no subject's row
  /// Common time window: from the latest first groundtruth row to the earliest last odometry row over
  /// all robots (absolute dataset time). A robot moves only once its odometry starts; past the end of
  /// its groundtruth its truth is NaN (unscored).
  double start_time_s = 0.0;
  double end_time_s = 0.0;
};

inline constexpr int kMrclamRobots = 5;
/// Groundtruth rows further apart than this leave the truth between them unknown: steps inside are not
/// scored (linear interpolation over 0.5 s errs by under a centimetre at MRCLAM's speeds and turn rates).
inline constexpr double kMrclamMaxTruthGapS = 0.5;

/// Reads Barcodes, Landmark_Groundtruth and Robot{1..5}_{Groundtruth,Odometry,Measurement} from
/// `directory` (each file as NAME.dat or NAME.dat.gz). Throws config::ScenarioError naming the file and
/// line for a missing file, an unparsable or non-finite row, or times that go backwards.
MrclamDataset load_mrclam(const std::filesystem::path& directory);

/// The dataset cut into world steps of scenario.world.data_step_s seconds from start_time_s:
/// step k covers dataset time (t_{k−1}, t_k], t_k = start + k·dt. Its batch carries the odometry
/// segments of that interval and the measurements timestamped in it (step 0: none), with the noise of
/// scenario.noise (the odometry of the commands in force noise.odometry_lag_s earlier; the range less the
/// camera's bias at its bearing, noise.range_bias_*, and a robot sighting's less noise.robot_range_bias_m;
/// the range std of
/// noise.range_model at that range, bearing_std_rad,
/// odometry_v_std, odometry_omega_std); the truth is the
/// groundtruth interpolated at t_k.
class MrclamSteps final : public RecordedSteps {
 public:
  MrclamSteps(std::shared_ptr<const MrclamDataset> data, const config::Scenario& scenario);
  [[nodiscard]] std::int64_t steps() const override { return steps_; }
  [[nodiscard]] std::vector<Vec2> truth(std::int64_t step) const override;
  [[nodiscard]] estimators::MeasurementBatch batch(AgentId agent, std::int64_t step) const override;
  [[nodiscard]] double truth_heading(AgentId agent, std::int64_t step) const override {
    return pose_at(agent, step).heading_rad;
  }
  /// Groundtruth pose of robot `agent` at dataset time start + step·dt (linear interpolation); NaN past
  /// the robot's groundtruth and, after step 0, inside a gap of more than kMrclamMaxTruthGapS.
  [[nodiscard]] MrclamDataset::TimedPose pose_at(AgentId agent, std::int64_t step) const;
  /// Dataset time of world step `step` (seconds since start_time_s).
  [[nodiscard]] double time_of(std::int64_t step) const { return static_cast<double>(step) * step_s_; }

 private:
  std::shared_ptr<const MrclamDataset> data_;
  double step_s_;
  std::int64_t steps_;
  /// The camera's range bias at a measured bearing (noise.range_bias_*), removed from every sighting.
  [[nodiscard]] double range_bias_at(double bearing_rad) const {
    return range_noise_.range_bias_m + range_noise_.range_bias_per_rad * bearing_rad +
           range_noise_.range_bias_per_rad2 * bearing_rad * bearing_rad;
  }
  config::Scenario::Noise range_noise_;  ///< range_std_at(the range with its bias removed), the bias
  double bearing_std_rad_;
  double odometry_v_std_;
  double odometry_omega_std_;
  double odometry_lag_s_;
};

/// The world of a scenario with world.source = mrclam: five agents (no anchors), a complete
/// communication graph, truth and initial guesses (position and heading) from the groundtruth at the
/// start, and World::recorded set to MrclamSteps. Throws config::ScenarioError for unreadable data or
/// world.agents != 5.
World build_mrclam_world(const config::Scenario& scenario);

/// The baselines of a MRCLAM run, computed in-process on the same steps: dead reckoning (odometry
/// only) and the centralized pose EKF (one joint filter over the five robots, full robot-robot
/// Jacobians). RMSE over the five robots, whole run (same definition as summary.json's whole_run) and
/// at the final step.
///
/// Each also has its 3-DOF NEES (world::pose_nees, 3 = consistent): the mean over every scored
/// robot-step (whole run) and over the final step's robots. The batch smoother (pose_smoother.hpp) is
/// solved from the centralized EKF's trajectory, with its iterations and wall time.
struct MrclamBaseline {
  double rmse_m = 0.0;
  double final_rmse_m = 0.0;
  double nees3 = 0.0;  ///< NaN: no robot-step with a usable covariance
  double final_nees3 = 0.0;
};
struct MrclamSmootherBaseline : MrclamBaseline {
  int iterations = 0;
  int gating_rounds = 0;
  bool converged = false;
  int range_bearings_used = 0;
  int range_bearings_gated = 0;
  double solve_s = 0.0;  ///< wall time of the solve (with the marginals)
};
struct MrclamBaselines {
  MrclamBaseline dead_reckoning;
  MrclamBaseline centralized_ekf;
  std::optional<MrclamSmootherBaseline> batch_smoother;  ///< with_smoother only
};
MrclamBaselines mrclam_baselines(const config::Scenario& scenario, const World& world,
                                 bool with_smoother = true);

}  // namespace swarmloc::world
