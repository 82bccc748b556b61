#pragma once
// TUM trajectory export (trajectories/): one file per agent for the estimate and one for the ground
// truth, each line `timestamp x y z qx qy qz qw` with the world time of the step in seconds, z = 0 and
// the identity quaternion (0 0 0 1). Readable by evo, rpg_trajectory_evaluation and friends.
#include <filesystem>

#include "swarmloc/rundir/run_record.hpp"

namespace swarmloc::rundir {

/// Writes trajectories/agent_<id>.tum and trajectories/agent_<id>_truth.tum under `directory` for every
/// agent with recorded estimates. Does nothing (and creates nothing) if the record holds no estimates.
/// Returns the number of agents written. Throws OutputError if a file did not make it to disk.
/// `control.cancel` is polled per agent (Cancelled).
int write_tum_trajectories(const std::filesystem::path& directory, const RunRecord& record,
                           const world::WorkControl& control = {});

}  // namespace swarmloc::rundir
