// swarmloc — cooperative localization with one OS process per agent over Cyclone DDS.
// Exit codes: 0 ok, 2 bad input (scenario, flags), 1 runtime failure.
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <array>
#include <cerrno>
#include <climits>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "agent_command.hpp"
#include "agent_node.hpp"
#include "calibrate.hpp"
#include "cli_support.hpp"
#include "console.hpp"
#include "fusion_center.hpp"
#include "monitor.hpp"
#include "murp_replay.hpp"
#include "orchestrator.hpp"
#include "replay.hpp"
#include "swarmloc/config/scenario.hpp"
#include "uwb_team_agent.hpp"

namespace {

using swarmloc::orchestrator::kPositiveInteger;

std::string keys_help() {
  std::string text = "Keys accepted by --set (see docs/scenario.md):\n";
  std::string line = " ";
  for (const auto& key : swarmloc::config::known_keys()) {
    if (line.size() + key.size() > 100) text += line + "\n", line = " ";
    line += " " + key;
  }
  return text + line + "\n";
}

/// --view [PORT] and --view-hold S on `run` and `sim`.
void add_view_options(CLI::App* command, int& port, double& hold_s) {
  command
      ->add_option("--view", port,
                   "Serve a live view on http://127.0.0.1:PORT/ (default port 8765; 0 = any free port). "
                   "Put it after the scenario, or write --view=PORT")
      ->expected(0, 1)
      ->default_str("8765")
      ->check(CLI::Range(0, 65535));
  command
      ->add_option("--view-hold", hold_s,
                   "With --view: keep serving the final state this many seconds after the run "
                   "(default 10; inf = until Ctrl-C)")
      ->check(CLI::Validator(
          [](const std::string& text) -> std::string {
            char* end = nullptr;
            const double value = std::strtod(text.c_str(), &end);
            const bool parsed = end != text.c_str() && *end == '\0';
            if (parsed && value >= 0.0) return {};  // NaN compares false
            return "'" + text + "' must be a number of seconds >= 0, or inf";
          },
          "SECONDS >= 0 or inf"));
}

/// --force on run, sim and replay.
void add_force_flag(CLI::App* command, bool& force) {
  command->add_flag("--force", force,
                    "Replace the earlier run in a non-empty --out directory (only a swarmloc run directory "
                    "is ever cleared)");
}

/// `swarmloc frobnicate`: name the unknown word and list the commands (CLI11 would only say that a
/// subcommand is required, or that an argument was not expected).
bool reject_unknown_command(const CLI::App& app, int argc, char** argv) {
  if (argc >= 2 && argv[1][0] == '-') return false;
  const std::string word = argc >= 2 ? argv[1] : "";
  std::string names;
  for (const auto* command : app.get_subcommands([](const CLI::App*) { return true; })) {
    if (command->get_name() == word) return false;
    names += (names.empty() ? "" : ", ") + command->get_name();
  }
  if (word.empty()) {
    std::fprintf(stderr, "error: a command is required (commands: %s; see swarmloc --help)\n", names.c_str());
  } else {
    std::fprintf(stderr, "error: unknown command '%s' (commands: %s; see swarmloc --help)\n", word.c_str(),
                 names.c_str());
  }
  return true;
}

/// Flags that several commands offer, bound to the same variables (only one command is parsed).
struct SharedFlags {
  std::string scenario_path;
  std::vector<std::string> overrides;
  std::string out_dir;
  bool quiet = false;
  bool record = false;
  bool force = false;
  std::string security_dir;
  int trial = -1;  ///< --trial K; -1: not given (trial 0)
};

/// --trial K: the world of trial K of a Monte Carlo set (its guesses, motion, draws, loss).
CLI::Option* add_trial_option(CLI::App* command, SharedFlags& shared) {
  return command
      ->add_option(
          "--trial", shared.trial,
          "Run only trial K of a Monte Carlo set (0 = the first; its row in trials.csv) and write its "
          "run directory in full")
      ->check(CLI::NonNegativeNumber);
}

const char* const kRecordHelp =
    "Write recording.slrec (truth and every measurement batch) and recording/ (the inter-agent samples "
    "each agent received) into the run directory; replay with `swarmloc replay` (docs/record-replay.md)";
const char* const kSecurityHelp =
    "DDS Security with the PKI in DIR (deploy/security/make-pki.sh); same as --set dds.security_dir=DIR";

/// `swarmloc run`.
struct RunCommand {
  CLI::App* command = nullptr;
  std::vector<int> hostile;
  bool no_launch = false;
  int view_port = -1;
  double view_hold = 10.0;
};

void add_run_command(CLI::App& app, SharedFlags& shared, RunCommand& run) {
  auto* command = app.add_subcommand(
      "run", "Run a scenario with one OS process per agent over DDS (orchestrator + agents).");
  run.command = command;
  command->add_option("scenario", shared.scenario_path, "Scenario YAML file (e.g. scenarios/default.yaml)")
      ->required();
  command->add_option("--out", shared.out_dir, "Run directory (default: runs/<name>-<utc stamp>-seed<seed>)");
  command->add_option("--set", shared.overrides,
                      "Override a scenario key: --set network.loss=0.2 (repeatable)");
  command->add_option("--hostile", run.hostile,
                      "Start this agent id as a hostile agent publishing NaN / non-PSD / absurd states");
  command->add_flag("--no-launch", run.no_launch,
                    "Do not start agents; wait for agents started elsewhere (containers, hosts)");
  command->add_flag("-q,--quiet", shared.quiet, "No progress line");
  command->add_flag("--record", shared.record, kRecordHelp);
  command->add_option("--security", shared.security_dir, kSecurityHelp);
  add_trial_option(command, shared);
  add_view_options(command, run.view_port, run.view_hold);
  add_force_flag(command, shared.force);
  command->footer(keys_help());
}

int execute_run(const RunCommand& run, const SharedFlags& shared, const char* argv0) {
  swarmloc::orchestrator::RunOptions options;
  options.scenario_path = shared.scenario_path;
  options.overrides = shared.overrides;
  options.out_dir = shared.out_dir;
  options.agent_binary = swarmloc::orchestrator::self_executable(argv0).string();
  options.launch_agents = !run.no_launch;
  options.hostile_agents.assign(run.hostile.begin(), run.hostile.end());
  options.progress = !shared.quiet;
  options.view_port = run.view_port;
  options.view_hold_s = run.view_hold;
  options.record = shared.record;
  options.force = shared.force;
  if (shared.trial >= 0) options.trial = static_cast<std::uint64_t>(shared.trial);
  return swarmloc::orchestrator::run_orchestrator(options);
}

/// `swarmloc sim`.
struct SimCommand {
  CLI::App* command = nullptr;
  int trials = 1;
  int threads = 0;
  std::vector<int> hostile;
  int view_port = -1;
  double view_hold = 10.0;
};

void add_sim_command(CLI::App& app, SharedFlags& shared, SimCommand& sim) {
  auto* command = app.add_subcommand("sim",
                                     "Run a scenario in-process (same estimators, seeded bus; synchronous "
                                     "rounds, or per-agent clocks with run.sim_clock=agents).");
  sim.command = command;
  command->add_option("scenario", shared.scenario_path, "Scenario YAML file")->required();
  command->add_option("--out", shared.out_dir, "Run directory (default: runs/<name>-<utc stamp>-seed<seed>)");
  command->add_option("--set", shared.overrides, "Override a scenario key (repeatable)");
  command->add_flag("-q,--quiet", shared.quiet, "No progress line");
  command->add_flag("--record", shared.record, kRecordHelp);
  command
      ->add_option("--trials", sim.trials,
                   "Monte Carlo trials (fixed configuration; noise, initial guesses and loss per trial)")
      ->check(kPositiveInteger);
  add_trial_option(command, shared)->excludes("--trials");
  command
      ->add_option("--threads", sim.threads,
                   "Worker threads: trials with --trials (default: every core), else the agents of one round "
                   "(default: every core from 1000 agents on, else 1; results do not depend on it)")
      ->check(CLI::NonNegativeNumber);
  command->add_option("--hostile", sim.hostile,
                      "This agent publishes NaN / non-PSD / absurd samples, as in `run --hostile`");
  add_view_options(command, sim.view_port, sim.view_hold);
  add_force_flag(command, shared.force);
  command->footer(keys_help());
}

int execute_sim(const SimCommand& sim, const SharedFlags& shared) {
  swarmloc::orchestrator::SimCommandOptions options;
  options.scenario_path = shared.scenario_path;
  options.overrides = shared.overrides;
  options.out_dir = shared.out_dir;
  options.progress = !shared.quiet;
  options.trials = sim.trials;
  if (shared.trial >= 0) options.trial = static_cast<std::uint64_t>(shared.trial);
  options.threads = sim.threads;
  options.view_port = sim.view_port;
  options.view_hold_s = sim.view_hold;
  options.hostile_agents.assign(sim.hostile.begin(), sim.hostile.end());
  options.record = shared.record;
  options.force = shared.force;
  return swarmloc::orchestrator::run_sim_command(options);
}

/// `swarmloc agent`: one agent process, or the fusion centre of a centralized algorithm.
struct AgentCommand {
  CLI::App* command = nullptr;
  swarmloc::agent::AgentOptions options;
  std::string role = "agent";
  CLI::Option* id = nullptr;
  int domain = -1;                           ///< --domain: dds.domain_id
  std::string run_id;                        ///< --run-id: dds.run_id
  swarmloc::agent::UwbTeamAgentOptions uwb;  ///< --uwb-team: a vehicle of `replay --murp`
  bool no_cooperation = false;
};

void add_agent_command(CLI::App& app, SharedFlags& shared, AgentCommand& agent) {
  auto* command =
      app.add_subcommand("agent", "Run one agent process (what `run` starts N times; also for containers).");
  agent.command = command;
  auto& options = agent.options;
  command->add_option("--scenario", options.scenario_path,
                      "Scenario YAML (the run directory's scenario.yaml; needed with --manifest and --role "
                      "fusion). Without it the agent takes the run's scenario from its manifest sample");
  command
      ->add_option("--role", agent.role,
                   "agent: one agent (needs --id); fusion: the fusion centre of a centralized algorithm "
                   "(ekf, lbekf, lbekf_vr, lbekf_i)")
      ->check(CLI::IsMember({"agent", "fusion"}));
  agent.id = command->add_option("--id", options.id, "Agent id in [0, world.agents) (role agent)");
  command->add_option(
      "--manifest", options.manifest_path,
      "This agent's manifest (set by `swarmloc run`: <run>/manifests/agent_<id>.json); without it the "
      "agent waits for its manifest sample from `swarmloc run --no-launch` on DDS");
  command->add_option("--domain", agent.domain, "DDS domain of the run (same as --set dds.domain_id=N)")
      ->check(CLI::NonNegativeNumber);
  command->add_option("--run-id", agent.run_id,
                      "Run id (dds.run_id) whose manifest to take; default: any run on the domain");
  command
      ->add_option("--manifest-timeout", options.manifest_timeout_s,
                   "Without --manifest: seconds to wait for the manifest sample (default 60; exit 1 after)")
      ->check(CLI::PositiveNumber);
  command->add_option("--set", options.overrides, "Override a scenario key (repeatable)");
  command->add_option("--log", options.log_path, "Log file (default: stderr)");
  command
      ->add_option("--incarnation", options.incarnation,
                   "Restart count of this agent (set by the orchestrator for faults.kill restarts)")
      ->check(CLI::Range(0, 255));
  command->add_option("--security", shared.security_dir, kSecurityHelp);
  command->add_flag("--hostile", options.hostile, "Publish NaN / non-PSD / absurd states (robustness tests)");
  command->add_option("--record", options.record_path,
                      "Log every inter-agent sample received to FILE (set by `run --record`; "
                      "docs/record-replay.md)");
  auto* uwb = command->add_option("--uwb-team", agent.uwb.calibration_path,
                                  "MURP UWB team: be one vehicle of `replay --murp`, with the range model of "
                                  "calibration FILE (docs/real-data.md: MURP over DDS)");
  command->add_option("--vehicle", agent.uwb.vehicle, "UWB team: this vehicle's id")->needs(uwb);
  command->add_option("--team", agent.uwb.team, "UWB team: every vehicle's id, comma-separated (e.g. 1,2,3)")
      ->delimiter(',')
      ->needs(uwb);
  command->add_flag("--no-cooperation", agent.no_cooperation, "UWB team: report own-range estimates only")
      ->needs(uwb);
}

int execute_agent(AgentCommand& agent) {
  auto& options = agent.options;
  if (!agent.uwb.calibration_path.empty()) {
    agent.uwb.cooperate = !agent.no_cooperation;
    agent.uwb.domain_id = agent.domain >= 0 ? agent.domain : 0;
    agent.uwb.log_path = options.log_path;
    return swarmloc::agent::run_uwb_team_agent(agent.uwb);
  }
  // After the --set overrides, so the flags win.
  if (agent.domain >= 0) options.overrides.push_back("dds.domain_id=" + std::to_string(agent.domain));
  if (!agent.run_id.empty()) options.overrides.push_back("dds.run_id=" + agent.run_id);
  if (options.scenario_path.empty() && (agent.role == "fusion" || !options.manifest_path.empty())) {
    std::fprintf(stderr, "error: --scenario is required with --manifest and with --role fusion\n");
    return 2;
  }
  if (agent.role == "fusion") {
    if (agent.id->count() > 0 || options.hostile) {
      std::fprintf(stderr, "error: --role fusion takes no --id or --hostile\n");
      return 2;
    }
    return swarmloc::orchestrator::run_fusion_center(
        swarmloc::orchestrator::FusionOptions{options.scenario_path, options.overrides, options.log_path});
  }
  if (agent.id->count() == 0 && options.manifest_path.empty()) {
    std::fprintf(stderr, "error: --id (or --manifest) is required for --role agent\n");
    return 2;
  }
  return swarmloc::orchestrator::run_agent_command(options);
}

/// `swarmloc replay`.
struct ReplayCommand {
  CLI::App* command = nullptr;
  swarmloc::orchestrator::ReplayOptions options;
  swarmloc::orchestrator::MurpReplayOptions murp;
  bool no_cooperation = false;
};

void add_replay_command(CLI::App& app, SharedFlags& shared, ReplayCommand& replay) {
  auto* command = app.add_subcommand(
      "replay",
      "Feed a recording's measurements (recording.slrec from `run --record` / `sim --record`) to fresh "
      "agents, in the simulator or with --dds over DDS; --set algorithm.name=... compares algorithms on "
      "identical input.");
  replay.command = command;
  auto& options = replay.options;
  command->add_option("recording", options.recording_path,
                      "Recording file (a run directory's recording.slrec)");
  command->add_flag("--dds", options.dds, "Replay over DDS agent processes (default: the simulator)");
  command->add_option(
      "--mrclam", options.mrclam_dir,
      "UTIAS MRCLAM dataset directory (e.g. MRCLAM_Dataset6): five robots as five DDS agents, scored "
      "with dead-reckoning and centralized-EKF baselines (docs/real-data.md: where to get it)");
  command->add_option("--speedup", options.speedup,
                      "--mrclam: dataset seconds per wall-clock second (default 10)");
  command->add_option(
      "--murp", replay.murp.trial_dir,
      "MURP UWB trial directory (its six NN_base-A_targ-B files): three vehicles as three DDS "
      "agents estimating each other's relative pose (docs/real-data.md: MURP)");
  command->add_option(
      "--bias", replay.murp.bias_path,
      "--murp: the range calibration to use (a `swarmloc calibrate --murp --out` file; default: "
      "the built-in one, fitted on trials 01-12)");
  command->add_flag("--no-bias", replay.murp.no_bias, "--murp: no range-bias correction");
  command->add_flag("--no-cooperation", replay.no_cooperation,
                    "--murp: each vehicle on its own ranges (no loop closure with the others' estimates)");
  command->add_option("--domain", replay.murp.domain_id, "--murp: the DDS domain (default 0)");
  command->add_flag("--ros2", replay.murp.ros2,
                    "--murp over DDS: also publish every vehicle's relative pose of each peer and its truth "
                    "on ROS 2 topics /swarmloc/murp/vehicle_A/vehicle_B/{pose,truth} (docs/ros2.md)");
  command
      ->add_option("--ros2-subscribers", replay.murp.ros2_subscribers,
                   "--ros2: before the first window, wait (at most 30 s) until N ROS 2 readers have matched "
                   "those topics, one per subscriber and topic (default 0: no wait)")
      ->check(CLI::NonNegativeNumber);
  command->add_flag("--sim", options.in_process,
                    "--mrclam, --murp: run in the in-process simulator, not over DDS");
  command->add_option("--noise", options.noise_path,
                      "--mrclam: replay with this noise model (a `swarmloc calibrate --out` file) instead of "
                      "the dataset's own, measured from its groundtruth");
  command->add_option("--out", shared.out_dir, "Run directory (default: runs/<name>-<utc stamp>-seed<seed>)");
  command->add_option("--set", shared.overrides,
                      "Override a key of the recorded scenario (repeatable; not seed or world.*, which would "
                      "change the recorded world)");
  command->add_flag("--record", shared.record,
                    "Record the replay as well (e.g. the inter-agent samples of another algorithm)");
  command->add_flag("-q,--quiet", shared.quiet, "No progress line");
  add_force_flag(command, shared.force);
  command->footer(keys_help());
}

int execute_murp_replay(ReplayCommand& replay, const SharedFlags& shared, const char* argv0) {
  const auto& options = replay.options;
  if (!options.recording_path.empty() || !options.mrclam_dir.empty() || !options.noise_path.empty() ||
      options.dds || !shared.overrides.empty() || shared.record) {
    std::fprintf(stderr,
                 "error: replay --murp takes no recording, --mrclam, --noise, --dds, --set or --record\n");
    return 2;
  }
  auto& murp = replay.murp;
  if (murp.ros2 && options.in_process) {
    std::fprintf(
        stderr,
        "error: --ros2 publishes from the DDS run's orchestrator; --sim runs without DDS (drop one)\n");
    return 2;
  }
  if (murp.ros2_subscribers > 0 && !murp.ros2) {
    std::fprintf(stderr, "error: --ros2-subscribers applies to --ros2\n");
    return 2;
  }
  murp.cooperate = !replay.no_cooperation;
  murp.in_process = options.in_process;
  murp.out_dir = shared.out_dir;
  murp.force = shared.force;
  murp.progress = !shared.quiet;
  murp.agent_binary = swarmloc::orchestrator::self_executable(argv0).string();
  return swarmloc::orchestrator::run_murp_replay(murp);
}

int execute_replay(ReplayCommand& replay, const SharedFlags& shared, const char* argv0) {
  if (!replay.murp.trial_dir.empty()) return execute_murp_replay(replay, shared, argv0);
  if (!replay.murp.bias_path.empty() || replay.murp.no_bias || replay.no_cooperation || replay.murp.ros2 ||
      replay.murp.ros2_subscribers > 0) {
    std::fprintf(
        stderr,
        "error: --bias, --no-bias, --no-cooperation, --ros2 and --ros2-subscribers apply to --murp DIR "
        "(other runs publish on ROS 2 with --set dds.ros2=true)\n");
    return 2;
  }
  auto& options = replay.options;
  options.overrides = shared.overrides;
  options.out_dir = shared.out_dir;
  options.progress = !shared.quiet;
  options.record = shared.record;
  options.force = shared.force;
  options.agent_binary = swarmloc::orchestrator::self_executable(argv0).string();
  return swarmloc::orchestrator::run_replay(options);
}

/// `swarmloc calibrate`.
struct CalibrateCommand {
  CLI::App* command = nullptr;
  swarmloc::orchestrator::CalibrateOptions options;
};

void add_calibrate_command(CLI::App& app, CalibrateCommand& calibrate) {
  auto* command = app.add_subcommand(
      "calibrate",
      "Measure a UTIAS MRCLAM dataset's range, bearing and odometry noise (and biases) against its "
      "groundtruth, or fit the MURP UWB dataset's range model to its trials' motion capture; print how each "
      "figure was measured and write them to a file (docs/real-data.md).");
  calibrate.command = command;
  auto* mrclam =
      command->add_option("--mrclam", calibrate.options.mrclam_dir, "UTIAS MRCLAM dataset directory");
  auto* murp = command
                   ->add_option("--murp", calibrate.options.murp_dirs,
                                "MURP UWB trial directories (parsed/NN; e.g. the calibration trials 01-12): "
                                "fit the range bias and noise model")
                   ->expected(1, -1);
  mrclam->excludes(murp);
  command->add_option(
      "--out", calibrate.options.out_path,
      "Write the figures to FILE: --mrclam the noise.* scenario keys (YAML), --murp the range "
      "model (JSON)");
}

/// `swarmloc monitor`.
struct MonitorCommand {
  CLI::App* command = nullptr;
  swarmloc::orchestrator::MonitorOptions options;
};

void add_monitor_command(CLI::App& app, MonitorCommand& monitor) {
  auto* command = app.add_subcommand(
      "monitor",
      "Join a live deployment's domain, record every robot's pose (and ground truth, if published) and "
      "write a run directory scored against the truth (docs/live.md).");
  monitor.command = command;
  auto& options = monitor.options;
  command->add_option("--deployment", options.deployment_path, "The deployment file the agents run")
      ->required();
  command->add_option("--out", options.out_dir, "Run directory")->required();
  command->add_option("--truth-topic", options.truth_topic,
                      "Ground-truth topic in each robot's namespace (geometry_msgs/PoseStamped; default: the "
                      "deployment's topics.truth; none: no truth)");
  command->add_option("--duration", options.duration_s, "Stop after S seconds (default: at Ctrl-C or idle)")
      ->check(CLI::PositiveNumber);
  command
      ->add_option("--idle", options.idle_s, "Stop once poses came and then none for S seconds (default 5)")
      ->check(CLI::PositiveNumber);
  command
      ->add_option("--view", options.view_port,
                   "Serve the live view on http://127.0.0.1:PORT/ (0 = any free port; docs/live_view.md)")
      ->check(CLI::Range(0, 65535));
  command->add_flag("-q,--quiet", options.quiet, "No progress line");
  add_force_flag(command, options.force);
}

/// Parses the command line; returns the exit code when it is the end (help, errors), else nothing.
std::optional<int> parse_command_line(CLI::App& app, int argc, char** argv) {
  if (reject_unknown_command(app, argc, argv)) return 2;
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return 2;
  }
  return std::nullopt;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "swarmloc: cooperative localization of sensor networks and robot teams.\n"
      "Each agent is its own OS process talking over Cyclone DDS; the orchestrator owns the ground truth,\n"
      "feeds every agent its noisy measurements, and scores the estimates against truth and the CRLB.\n\n"
      "  swarmloc run scenarios/default.yaml            # N agent processes over DDS on loopback\n"
      "  swarmloc sim scenarios/default.yaml            # the same estimators in one process\n"
      "  swarmloc run scenarios/default.yaml --set network.loss=0.2 --set world.agents=40\n"
      "  swarmloc sim scenarios/default.yaml --record --out runs/a     # record every measurement\n"
      "  swarmloc replay runs/a/recording.slrec --set algorithm.name=iekf  # another algorithm\n"
      "  swarmloc calibrate --mrclam DIR --out noise.yaml  # a dataset's noise from its groundtruth\n"
      "  swarmloc calibrate --murp parsed/01 ... parsed/12 --out murp.json  # MURP range bias and noise\n"
      "  swarmloc monitor --deployment lab.yaml --out runs/lab   # record live robots (docs/live.md)\n\n"
      "Paper reproductions and parameter campaigns: swarmloc-research (docs/reproduction.md).\n",
      "swarmloc"};
  app.require_subcommand(1);
  app.footer("Exit codes: 0 ok, 2 bad input (scenario or flags), 1 runtime failure or interrupted.");

  SharedFlags shared;
  RunCommand run;
  SimCommand sim;
  AgentCommand agent;
  ReplayCommand replay;
  add_run_command(app, shared, run);
  add_sim_command(app, shared, sim);
  add_agent_command(app, shared, agent);
  add_replay_command(app, shared, replay);
  MonitorCommand monitor;
  add_monitor_command(app, monitor);
  CalibrateCommand calibrate;
  add_calibrate_command(app, calibrate);

  // A file size limit (ulimit -f) must fail a write with EFBIG, named like a full disk, not kill us.
  std::signal(SIGXFSZ, SIG_IGN);
  if (const auto exit_code = parse_command_line(app, argc, argv)) return *exit_code;

  swarmloc::orchestrator::log_above_progress_line();
  spdlog::set_pattern("%H:%M:%S.%e %^%l%$ %v");
  if (!shared.security_dir.empty()) {
    // After the --set overrides, so the flag wins.
    shared.overrides.push_back("dds.security_dir=" + shared.security_dir);
    agent.options.overrides.push_back("dds.security_dir=" + shared.security_dir);
  }
  if (run.command->parsed()) return execute_run(run, shared, argv[0]);
  if (sim.command->parsed()) return execute_sim(sim, shared);
  if (agent.command->parsed()) return execute_agent(agent);
  if (replay.command->parsed()) return execute_replay(replay, shared, argv[0]);
  if (monitor.command->parsed()) return swarmloc::orchestrator::run_monitor(monitor.options);
  if (calibrate.command->parsed()) return swarmloc::orchestrator::run_calibrate(calibrate.options);
  return 2;
}
