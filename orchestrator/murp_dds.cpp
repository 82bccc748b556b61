// Placeholder until the DDS team runner lands (branch murp-dds): the DDS mode reports that it is missing.
#include "murp_dds.hpp"

namespace swarmloc::orchestrator {

MurpDdsRun run_murp_over_dds(const std::vector<world::MurpTeamWindow>& /*windows*/,
                             const MurpDdsOptions& /*options*/) {
  MurpDdsRun run;
  run.failed = true;
  run.failure = "replay --murp over DDS is not built yet; use --sim";
  return run;
}

}  // namespace swarmloc::orchestrator
