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
#include <string>

#include "agent_node.hpp"
#include "fusion_center.hpp"
#include "orchestrator.hpp"
#include "replay.hpp"
#include "swarmloc/config/scenario.hpp"

namespace {

std::string self_executable(const char* argv0) {
  std::array<char, 4096> buffer{};
  const ssize_t length = readlink("/proc/self/exe", buffer.data(), buffer.size() - 1);
  if (length > 0) return std::string(buffer.data(), static_cast<std::size_t>(length));
  return std::filesystem::absolute(argv0).string();
}

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

/// CLI::PositiveNumber's message prints the double range 0 to 1.8e308; this one says what is wanted.
const CLI::Validator kPositiveInteger(
    [](const std::string& text) -> std::string {
      char* end = nullptr;
      errno = 0;
      const long value = std::strtol(text.c_str(), &end, 10);
      if (end != text.c_str() && *end == '\0' && errno == 0 && value >= 1 && value <= INT_MAX) return {};
      return "'" + text + "' must be a positive integer";
    },
    "INT >= 1");

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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "swarmloc: cooperative localization of sensor networks and robot teams.\n"
      "Each agent is its own OS process talking over Cyclone DDS; the orchestrator owns the ground truth,\n"
      "feeds every agent its noisy measurements, and scores the estimates against truth and the CRLB.\n\n"
      "  swarmloc run scenarios/default.yaml            # N agent processes over DDS on loopback\n"
      "  swarmloc sim scenarios/default.yaml            # the same estimators in one process\n"
      "  swarmloc run scenarios/default.yaml --set network.loss=0.2 --set world.agents=40\n"
      "  swarmloc campaign scenarios/campaigns/loss.yaml --mode sim   # loss sweep, every algorithm\n"
      "  swarmloc sim scenarios/default.yaml --record --out runs/a     # record every measurement\n"
      "  swarmloc replay runs/a/recording.slrec --set algorithm.name=iekf  # another algorithm\n\n"
      "Paper reproductions and parameter campaigns: swarmloc-research (docs/reproduction.md).\n",
      "swarmloc"};
  app.require_subcommand(1);
  app.footer("Exit codes: 0 ok, 2 bad input (scenario or flags), 1 runtime failure or interrupted.");

  std::string scenario_path;
  std::vector<std::string> overrides;
  std::string out_dir;
  bool quiet = false;

  auto* run = app.add_subcommand(
      "run", "Run a scenario with one OS process per agent over DDS (orchestrator + agents).");
  std::vector<int> hostile;
  bool no_launch = false;
  run->add_option("scenario", scenario_path, "Scenario YAML file (e.g. scenarios/default.yaml)")->required();
  run->add_option("--out", out_dir, "Run directory (default: runs/<name>-<utc stamp>-seed<seed>)");
  run->add_option("--set", overrides, "Override a scenario key: --set network.loss=0.2 (repeatable)");
  run->add_option("--hostile", hostile,
                  "Start this agent id as a hostile agent publishing NaN / non-PSD / absurd states");
  run->add_flag("--no-launch", no_launch,
                "Do not start agents; wait for agents started elsewhere (containers, hosts)");
  run->add_flag("-q,--quiet", quiet, "No progress line");
  bool record = false;
  const std::string record_help =
      "Write recording.slrec (truth and every measurement batch) and recording/ (the inter-agent samples "
      "each agent received) into the run directory; replay with `swarmloc replay` (docs/record-replay.md)";
  run->add_flag("--record", record, record_help);
  std::string security_dir;
  const std::string security_help =
      "DDS Security with the PKI in DIR (deploy/security/make-pki.sh); same as --set dds.security_dir=DIR";
  run->add_option("--security", security_dir, security_help);
  int run_view_port = -1;
  double run_view_hold = 10.0;
  add_view_options(run, run_view_port, run_view_hold);
  bool force = false;
  add_force_flag(run, force);
  run->footer(keys_help());

  auto* sim = app.add_subcommand("sim",
                                 "Run a scenario in-process (same estimators, seeded bus; synchronous "
                                 "rounds, or per-agent clocks with run.sim_clock=agents).");
  sim->add_option("scenario", scenario_path, "Scenario YAML file")->required();
  sim->add_option("--out", out_dir, "Run directory (default: runs/<name>-<utc stamp>-seed<seed>)");
  sim->add_option("--set", overrides, "Override a scenario key (repeatable)");
  sim->add_flag("-q,--quiet", quiet, "No progress line");
  sim->add_flag("--record", record, record_help);
  int trials = 1;
  int threads = 0;
  sim->add_option("--trials", trials,
                  "Monte Carlo trials (fixed configuration; noise, initial guesses and loss per trial)")
      ->check(kPositiveInteger);
  sim->add_option("--threads", threads,
                  "Worker threads: trials with --trials (default: every core), else the agents of one round "
                  "(default: every core from 1000 agents on, else 1; results do not depend on it)")
      ->check(CLI::NonNegativeNumber);
  std::vector<int> sim_hostile;
  sim->add_option("--hostile", sim_hostile,
                  "This agent publishes NaN / non-PSD / absurd samples, as in `run --hostile`");
  int sim_view_port = -1;
  double sim_view_hold = 10.0;
  add_view_options(sim, sim_view_port, sim_view_hold);
  add_force_flag(sim, force);
  sim->footer(keys_help());

  auto* agent =
      app.add_subcommand("agent", "Run one agent process (what `run` starts N times; also for containers).");
  swarmloc::agent::AgentOptions agent_options;
  agent
      ->add_option("--scenario", agent_options.scenario_path,
                   "Scenario YAML (the run directory's scenario.yaml)")
      ->required();
  std::string agent_role = "agent";
  agent
      ->add_option("--role", agent_role,
                   "agent: one agent (needs --id); fusion: the fusion centre of a centralized algorithm "
                   "(ekf, lbekf, lbekf_vr, lbekf_i)")
      ->check(CLI::IsMember({"agent", "fusion"}));
  auto* agent_id = agent->add_option("--id", agent_options.id, "Agent id in [0, world.agents) (role agent)");
  agent->add_option("--set", agent_options.overrides, "Override a scenario key (repeatable)");
  agent->add_option("--log", agent_options.log_path, "Log file (default: stderr)");
  agent
      ->add_option("--incarnation", agent_options.incarnation,
                   "Restart count of this agent (set by the orchestrator for faults.kill restarts)")
      ->check(CLI::Range(0, 255));
  agent
      ->add_option("--world-draw", agent_options.world_draw,
                   "Set by `swarmloc run`: the world draw the orchestrator accepted, so the agent does not "
                   "repeat the localizability check (a wrong value gives the agent another world)")
      ->check(CLI::Range(0, 999));
  agent->add_option("--security", security_dir, security_help);
  agent->add_flag("--hostile", agent_options.hostile,
                  "Publish NaN / non-PSD / absurd states (robustness tests)");
  agent->add_option("--record", agent_options.record_path,
                    "Log every inter-agent sample received to FILE (set by `run --record`; "
                    "docs/record-replay.md)");

  auto* replay = app.add_subcommand(
      "replay",
      "Feed a recording's measurements (recording.slrec from `run --record` / `sim --record`) to fresh "
      "agents, in the simulator or with --dds over DDS; --set algorithm.name=... compares algorithms on "
      "identical input.");
  swarmloc::orchestrator::ReplayOptions replay_options;
  replay->add_option("recording", replay_options.recording_path,
                     "Recording file (a run directory's recording.slrec)");
  replay->add_flag("--dds", replay_options.dds, "Replay over DDS agent processes (default: the simulator)");
  replay->add_option(
      "--mrclam", replay_options.mrclam_dir,
      "UTIAS MRCLAM dataset directory (e.g. ../shared/data/utias-mrclam/MRCLAM_Dataset6): five "
      "robots as five DDS agents, scored with dead-reckoning and centralized-EKF baselines "
      "(docs/real-data.md)");
  replay->add_option("--speedup", replay_options.speedup,
                     "--mrclam: dataset seconds per wall-clock second (default 10)");
  replay->add_flag("--sim", replay_options.in_process,
                   "--mrclam: run in the in-process simulator, not over DDS");
  replay->add_option("--out", out_dir, "Run directory (default: runs/<name>-<utc stamp>-seed<seed>)");
  replay->add_option("--set", overrides,
                     "Override a key of the recorded scenario (repeatable; not seed or world.*, which would "
                     "change the recorded world)");
  replay->add_flag("--record", record,
                   "Record the replay as well (e.g. the inter-agent samples of another algorithm)");
  replay->add_flag("-q,--quiet", quiet, "No progress line");
  add_force_flag(replay, force);
  replay->footer(keys_help());

  // A file size limit (ulimit -f) must fail a write with EFBIG, named like a full disk, not kill us.
  std::signal(SIGXFSZ, SIG_IGN);
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

  spdlog::set_pattern("%H:%M:%S.%e %^%l%$ %v");
  if (!security_dir.empty()) {
    // After the --set overrides, so the flag wins.
    overrides.push_back("dds.security_dir=" + security_dir);
    agent_options.overrides.push_back("dds.security_dir=" + security_dir);
  }
  if (run->parsed()) {
    swarmloc::orchestrator::RunOptions options;
    options.scenario_path = scenario_path;
    options.overrides = overrides;
    options.out_dir = out_dir;
    options.agent_binary = self_executable(argv[0]);
    options.launch_agents = !no_launch;
    options.hostile_agents.assign(hostile.begin(), hostile.end());
    options.progress = !quiet;
    options.view_port = run_view_port;
    options.view_hold_s = run_view_hold;
    options.record = record;
    options.force = force;
    return swarmloc::orchestrator::run_orchestrator(options);
  }
  if (sim->parsed()) {
    swarmloc::orchestrator::SimCommandOptions options;
    options.scenario_path = scenario_path;
    options.overrides = overrides;
    options.out_dir = out_dir;
    options.progress = !quiet;
    options.trials = trials;
    options.threads = threads;
    options.view_port = sim_view_port;
    options.view_hold_s = sim_view_hold;
    options.hostile_agents.assign(sim_hostile.begin(), sim_hostile.end());
    options.record = record;
    options.force = force;
    return swarmloc::orchestrator::run_sim_command(options);
  }
  if (agent->parsed()) {
    if (agent_role == "fusion") {
      if (agent_id->count() > 0 || agent_options.hostile) {
        std::fprintf(stderr, "error: --role fusion takes no --id or --hostile\n");
        return 2;
      }
      return swarmloc::agent::run_fusion_center(swarmloc::agent::FusionOptions{
          agent_options.scenario_path, agent_options.overrides, agent_options.log_path});
    }
    if (agent_id->count() == 0) {
      std::fprintf(stderr, "error: --id is required for --role agent\n");
      return 2;
    }
    return swarmloc::agent::run_agent(agent_options);
  }
  if (replay->parsed()) {
    replay_options.overrides = overrides;
    replay_options.out_dir = out_dir;
    replay_options.progress = !quiet;
    replay_options.record = record;
    replay_options.force = force;
    replay_options.agent_binary = self_executable(argv[0]);
    return swarmloc::orchestrator::run_replay(replay_options);
  }
  return 2;
}
