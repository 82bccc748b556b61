// swarmloc-agent — one agent process: its scenario file and its manifest (written by `swarmloc run` into
// <run>/manifests/), its estimator and the DDS transport. It links neither the world nor the simulator
// (nor SDPA/BLAS): what it may know is the manifest. `swarmloc agent` runs the same code.
// Exit codes: 0 ok, 2 bad input (scenario, manifest, flags), 1 runtime failure.
#include <CLI/CLI.hpp>
#include <csignal>
#include <string>

#include "agent_node.hpp"

int main(int argc, char** argv) {
  CLI::App app{"swarmloc-agent: one agent process of a `swarmloc run` (docs/architecture.md)"};
  swarmloc::agent::AgentOptions options;
  std::string security_dir;
  app.add_option("--scenario", options.scenario_path, "Scenario YAML (the run directory's scenario.yaml)")
      ->required();
  app.add_option("--manifest", options.manifest_path,
                 "This agent's manifest (<run>/manifests/agent_<id>.json)")
      ->required();
  app.add_option("--id", options.id, "Agent id (checked against the manifest)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--set", options.overrides, "Override a scenario key (repeatable)");
  app.add_option("--log", options.log_path, "Log file (default: stderr)");
  app.add_option("--incarnation", options.incarnation,
                 "Restart count of this agent (set by the orchestrator for faults.kill restarts)")
      ->check(CLI::Range(0, 255));
  app.add_option("--security", security_dir, "DDS Security directory (dds.security_dir)");
  app.add_flag("--hostile", options.hostile, "Publish NaN / non-PSD / absurd states (robustness tests)");
  app.add_option("--record", options.record_path, "Log every inter-agent sample received to FILE");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    const int code = app.exit(error);
    return code == 0 ? 0 : 2;
  }
  std::signal(SIGXFSZ, SIG_IGN);  // a file size limit fails a write (EFBIG) instead of killing us
  if (!security_dir.empty()) options.overrides.push_back("dds.security_dir=" + security_dir);
  return swarmloc::agent::run_agent(options);
}
