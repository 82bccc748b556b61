#include "agent_launch.hpp"

#include <algorithm>
#include <cstdio>

#include "swarmloc/rundir/recording.hpp"
#include "swarmloc/runtime/manifest.hpp"

namespace swarmloc::orchestrator {
std::vector<std::string> agent_executable(const std::string& agent_binary) {
  const auto lean = std::filesystem::path(agent_binary).parent_path() / "swarmloc-agent";
  if (std::filesystem::exists(lean)) return {lean.string()};
  return {agent_binary, "agent"};
}

ProcessCommand agent_process(const LaunchPlan& plan, AgentId id, int incarnation) {
  const auto scenario_file = (plan.run_dir / "scenario.yaml").string();
  char name[48];
  if (incarnation == 0) {
    std::snprintf(name, sizeof name, "agent_%03d.log", id);
  } else {
    std::snprintf(name, sizeof name, "agent_%03d.restart%d.log", id, incarnation);
  }
  const auto log = (plan.run_dir / "logs" / name).string();
  std::vector<std::string> argv = agent_executable(plan.agent_binary);
  argv.insert(argv.end(), {"--scenario", scenario_file, "--id", std::to_string(id), "--manifest",
                           runtime::manifest_path(plan.run_dir, id).string(), "--log", log});
  if (incarnation > 0) argv.insert(argv.end(), {"--incarnation", std::to_string(incarnation)});
  if (plan.record) {
    std::string file = name;  // agent_003.log -> recording/agent_003.slrec
    file.replace(file.size() - 4, 4, ".slrec");
    argv.insert(argv.end(), {"--record", (plan.run_dir / rundir::kSampleLogDirectory / file).string()});
  }
  if (std::find(plan.hostile_agents.begin(), plan.hostile_agents.end(), id) != plan.hostile_agents.end()) {
    argv.emplace_back("--hostile");
  }
  return {argv, log + ".out"};
}

ProcessCommand fusion_centre_process(const LaunchPlan& plan) {
  const auto log = (plan.run_dir / "logs" / "fusion_center.log").string();
  return {{plan.agent_binary, "agent", "--role", "fusion", "--scenario",
           (plan.run_dir / "scenario.yaml").string(), "--log", log},
          log + ".out"};
}

}  // namespace swarmloc::orchestrator
