// swarmloc-agent — one agent process: its scenario file and its manifest (written by `swarmloc run` into
// <run>/manifests/), or with --id alone the manifest sample of `swarmloc run --no-launch` over DDS (which
// carries the run's scenario); its estimator and the DDS transport. It links neither the world nor the
// simulator (nor SDPA/BLAS): what it may know is the manifest. `swarmloc agent` runs the same code. With
// --uwb-team, one vehicle of `swarmloc replay --murp` (uwb_team_agent.hpp) instead. Exit codes: 0 ok, 2 bad
// input (scenario, manifest, flags), 1 runtime failure.
#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdio>
#include <string>

#include "agent_node.hpp"
#include "live_agent.hpp"
#include "uwb_team_agent.hpp"

namespace {

/// `--uwb-team FILE --vehicle N --team 1,2,3 [--no-cooperation]`: a vehicle of `swarmloc replay --murp`.
struct UwbTeamFlags {
  swarmloc::agent::UwbTeamAgentOptions options;
  bool no_cooperation = false;
};

void add_uwb_team_flags(CLI::App& app, UwbTeamFlags& uwb) {
  auto* team = app.add_option("--uwb-team", uwb.options.calibration_path,
                              "MURP UWB team: be one vehicle of `swarmloc replay --murp`, with the range "
                              "model of calibration FILE (docs/real-data.md: MURP over DDS)");
  app.add_option("--vehicle", uwb.options.vehicle, "UWB team: this vehicle's id")->needs(team);
  app.add_option("--team", uwb.options.team, "UWB team: every vehicle's id, comma-separated (e.g. 1,2,3)")
      ->delimiter(',')
      ->needs(team);
  app.add_flag("--no-cooperation", uwb.no_cooperation, "UWB team: report own-range estimates only")
      ->needs(team);
}

int run_uwb_team(UwbTeamFlags& uwb, int domain, const std::string& log_path) {
  uwb.options.cooperate = !uwb.no_cooperation;
  uwb.options.domain_id = domain >= 0 ? domain : 0;
  uwb.options.log_path = log_path;
  return swarmloc::agent::run_uwb_team_agent(uwb.options);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"swarmloc-agent: one agent process of a `swarmloc run` (docs/architecture.md)"};
  swarmloc::agent::AgentOptions options;
  std::string security_dir;
  int domain = -1;
  std::string run_id;
  auto* scenario =
      app.add_option("--scenario", options.scenario_path,
                     "Scenario YAML (the run directory's scenario.yaml; default: the run's, from "
                     "the manifest sample)");
  app.add_option("--manifest", options.manifest_path,
                 "This agent's manifest (<run>/manifests/agent_<id>.json); without it the agent waits for "
                 "its manifest sample from `swarmloc run --no-launch` on DDS")
      ->needs(scenario);
  app.add_option("--id", options.id,
                 "Agent id: whose manifest to wait for on DDS (with --manifest: checked against it)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--domain", domain, "DDS domain of the run (same as --set dds.domain_id=N)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--run-id", run_id,
                 "Run id (dds.run_id) whose manifest to take; default: any run on the domain");
  app.add_option("--manifest-timeout", options.manifest_timeout_s,
                 "Without --manifest: seconds to wait for the manifest sample (default 60; exit 1 after)")
      ->check(CLI::PositiveNumber);
  app.add_option("--set", options.overrides, "Override a scenario key (repeatable)");
  app.add_option("--log", options.log_path, "Log file (default: stderr)");
  app.add_option("--incarnation", options.incarnation,
                 "Restart count of this agent (set by the orchestrator for faults.kill restarts)")
      ->check(CLI::Range(0, 255));
  app.add_option("--security", security_dir, "DDS Security directory (dds.security_dir)");
  app.add_flag("--hostile", options.hostile, "Publish NaN / non-PSD / absurd states (robustness tests)");
  app.add_option("--record", options.record_path, "Log every inter-agent sample received to FILE");
  swarmloc::agent::LiveOptions live;
  auto* live_flag = app.add_option("--live", live.deployment_path,
                                   "Live: take measurements from the robot's ROS 2 topics as deployment "
                                   "FILE describes, no orchestrator (docs/live.md)");
  app.add_option("--robot", live.robot, "Live: this robot's name in the deployment's team")->needs(live_flag);
  app.add_option("--stats", live.stats_path, "Live: write the input counters as JSON to FILE at exit")
      ->needs(live_flag);
  app.add_option("--duration", live.duration_s, "Live: stop after S seconds (default: at SIGINT/SIGTERM)")
      ->needs(live_flag)
      ->check(CLI::PositiveNumber);
  UwbTeamFlags uwb;
  add_uwb_team_flags(app, uwb);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    const int code = app.exit(error);
    return code == 0 ? 0 : 2;
  }
  std::signal(SIGXFSZ, SIG_IGN);  // a file size limit fails a write (EFBIG) instead of killing us
  if (!uwb.options.calibration_path.empty()) return run_uwb_team(uwb, domain, options.log_path);
  if (!live.deployment_path.empty()) {
    if (live.robot.empty()) {
      std::fprintf(stderr, "error: --live needs --robot NAME\n");
      return 2;
    }
    live.log_path = options.log_path;
    return swarmloc::agent::run_live_agent(live);
  }
  if (options.manifest_path.empty() && options.id < 0) {
    std::fprintf(stderr, "error: --id (or --manifest with --scenario) is required\n");
    return 2;
  }
  // After the --set overrides, so the flags win.
  if (!security_dir.empty()) options.overrides.push_back("dds.security_dir=" + security_dir);
  if (domain >= 0) options.overrides.push_back("dds.domain_id=" + std::to_string(domain));
  if (!run_id.empty()) options.overrides.push_back("dds.run_id=" + run_id);
  return swarmloc::agent::run_agent(options);
}
