// DDS Security end to end (issue 6 point 5): a PKI made by deploy/security/make-pki.sh, the real
// `swarmloc run` with dds.security_dir, and rogue `swarmloc agent --hostile` processes on the same
// domain that claim an honest agent's id — one with a certificate from another CA, one with no
// security at all. A control run without security shows that the same rogue set-up does reach the
// honest agents (its broken samples are received and rejected), so the zero counts of the secured run
// come from DDS Security and not from the rogues failing to discover anyone.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <fstream>
#include <iterator>
#include <thread>

#include "process_helpers.hpp"

namespace security_dds_test {
namespace {

using swarmloc::testing::count_processes_matching;
using swarmloc::testing::fresh_directory;
using swarmloc::testing::read_json;
using swarmloc::testing::read_text;
using swarmloc::testing::run_command;

const std::string kBinary = SWARMLOC_BINARY;
const std::string kScenario = std::string(SWARMLOC_SOURCE_DIR) + "/scenarios/ieif.yaml";
const std::string kMakePki = std::string(SWARMLOC_SOURCE_DIR) + "/deploy/security/make-pki.sh";

constexpr int kAgents = 8;
constexpr int kRogueId = 3;  // the rogues claim this honest agent's id (its neighbours, its partition)

// 8 agents (3 anchors) on 20 m x 20 m, 100 steps at 20 Hz. Lockstep makes a DDS run deterministic (it
// equals the simulator to 1e-9), so a secured and an unsecured run of the same seed must agree exactly.
std::string world_flags(int domain, const char* mode = "lockstep") {
  return " --set world.agents=" + std::to_string(kAgents) +
         " --set world.anchors=3 --set world.area_m=20 --set run.rate_hz=20 --set run.steps=100"
         " --set run.mode=" +
         mode + " --set dds.domain_id=" + std::to_string(domain);
}

/// The largest X of the agent's "matched X/Y neighbours" lines; -1 if it logged none.
int max_matched(const std::string& log) {
  int best = -1;
  for (auto at = log.find("matched "); at != std::string::npos; at = log.find("matched ", at + 1)) {
    const auto slash = log.find('/', at);
    if (slash == std::string::npos) break;
    try {
      best = std::max(best, std::stoi(log.substr(at + 8, slash - at - 8)));
    } catch (const std::exception&) {
    }
  }
  return best;
}

long rejected_total(const nlohmann::json& summary) {
  long total = 0;
  for (const auto& [reason, count] : summary["rejected_by_reason"].items()) total += count.get<long>();
  return total;
}

/// A rogue agent process in the background (`timeout` bounds it if the test dies), started 2 s after
/// the constructor so that the honest agents are up: Cyclone re-sends SPDP to an absent unicast peer
/// only slowly, and a rogue that starts first is found late even without security. It takes Cyclone
/// participant index `index` (the unused fusion-centre slot N + 1 and beyond), so it does not collide
/// with honest agent kRogueId's ports, and lists that agent's neighbours as its peers. It reads the run
/// directory's scenario.yaml, written by then, for the run id (every partition name starts with it), with
/// its own security setting (none: not the run's PKI, which that file names), and agent kRogueId's
/// manifest file (a stolen manifest: a launched run offers none over DDS).
struct Rogue {
  pid_t pid = -1;
  std::filesystem::path log;

  Rogue(const std::filesystem::path& dir, const std::string& name, const std::string& security, int index,
        int domain, const char* mode = "lockstep") {
    log = dir / (name + ".log");
    const std::string extra = "<CycloneDDS><Domain id=\"any\"><Discovery><ParticipantIndex>" +
                              std::to_string(index) + "</ParticipantIndex></Discovery></Domain></CycloneDDS>";
    const auto started =
        run_command("(sleep 2; SWARMLOC_CYCLONE_URI_EXTRA='" + extra + "' exec timeout -s TERM 120 " +
                    kBinary + " agent --scenario " + (dir / "run" / "scenario.yaml").string() + " --id " +
                    std::to_string(kRogueId) + " --manifest " +
                    (dir / "run" / "manifests" / ("agent_00" + std::to_string(kRogueId) + ".json")).string() +
                    " --hostile" + world_flags(domain, mode) +
                    (security.empty() ? " --set dds.security_dir=" : security) + " --log " + log.string() +
                    ") > " + (dir / (name + ".out")).string() + " 2>&1 & echo $!");
    pid = std::stoi(started.output);
  }
  /// SIGTERM (the agent exits cleanly), then the rogue's log.
  std::string stop() {
    ::kill(pid, SIGTERM);
    for (int i = 0; i < 100 && ::kill(pid, 0) == 0; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    return read_text(log);
  }
};

struct Pki {
  std::filesystem::path honest;
  std::filesystem::path foreign;  // same layout and subject names, different CAs
};

const Pki& pki() {
  static const Pki made = [] {
    const auto dir = fresh_directory("pki");
    Pki p{dir / "honest", dir / "foreign"};
    for (const auto& out : {p.honest, p.foreign}) {
      const auto result = run_command(kMakePki + " " + out.string() + " " + std::to_string(kAgents));
      EXPECT_EQ(result.exit_code, 0) << result.output;
    }
    return p;
  }();
  return made;
}

nlohmann::json run_dds(const std::filesystem::path& dir, const std::string& flags, int domain,
                       const char* mode = "lockstep") {
  const auto result = run_command(kBinary + " run " + kScenario + " -q --out " + (dir / "run").string() +
                                  world_flags(domain, mode) + flags);
  EXPECT_TRUE(swarmloc::testing::completed_run(result.exit_code)) << result.output;
  // The launched agents' logs are in the run directory (the rogues read its scenario.yaml, and live on).
  EXPECT_EQ(count_processes_matching((dir / "run" / "logs").string()), 0)
      << "agent processes outlived the run";
  return read_json(dir / "run" / "summary.json");
}

TEST(Security, PkiScriptIsIdempotentAndSignsEveryDocument) {
  const auto& p = pki();
  const auto cert = read_text(p.honest / "agent-0" / "cert.pem");
  ASSERT_EQ(run_command(kMakePki + " " + p.honest.string() + " " + std::to_string(kAgents)).exit_code, 0);
  EXPECT_EQ(read_text(p.honest / "agent-0" / "cert.pem"), cert) << "a second run must keep the identities";
  for (const std::string name : {"agent-0", "agent-7", "orchestrator", "fusion"}) {
    const auto verify = run_command("openssl verify -CAfile " + (p.honest / "identity_ca.pem").string() +
                                    " " + (p.honest / name / "cert.pem").string());
    EXPECT_EQ(verify.exit_code, 0) << verify.output;
    const auto smime =
        run_command("openssl smime -verify -text -CAfile " + (p.honest / "permissions_ca.pem").string() +
                    " -in " + (p.honest / name / "permissions.p7s").string() + " -out /dev/null");
    EXPECT_EQ(smime.exit_code, 0) << smime.output;
  }
  const auto foreign = run_command("openssl verify -CAfile " + (p.honest / "identity_ca.pem").string() + " " +
                                   (p.foreign / "agent-3" / "cert.pem").string());
  EXPECT_NE(foreign.exit_code, 0) << "the foreign PKI must not chain to the honest identity CA";
}

TEST(Security, MissingPkiIsBadInputNamingTheKey) {
  const auto dir = fresh_directory("sec-missing");
  const auto no_dir = run_command(kBinary + " run " + kScenario + " -q --out " + (dir / "run").string() +
                                  world_flags(53) + " --security " + (dir / "nope").string());
  EXPECT_EQ(no_dir.exit_code, 2) << no_dir.output;
  EXPECT_NE(no_dir.output.find("dds.security_dir"), std::string::npos) << no_dir.output;
  // A PKI for 2 agents lacks agent-2 … agent-7.
  ASSERT_EQ(run_command(kMakePki + " " + (dir / "small").string() + " 2").exit_code, 0);
  const auto small = run_command(kBinary + " run " + kScenario + " -q --out " + (dir / "run").string() +
                                 world_flags(53) + " --security " + (dir / "small").string());
  EXPECT_EQ(small.exit_code, 2) << small.output;
  EXPECT_NE(small.output.find("agent-2/cert.pem' is missing"), std::string::npos) << small.output;
}

TEST(Security, TamperedPermissionsDocumentIsRejected) {
  const auto dir = fresh_directory("sec-tamper");
  const auto copy = dir / "pki";
  std::filesystem::copy(pki().honest, copy, std::filesystem::copy_options::recursive);
  auto text = read_text(copy / "agent-1" / "permissions.p7s");
  const std::string own = "<partition>*.a1</partition>";
  const auto at = text.find(own);
  ASSERT_NE(at, std::string::npos);
  text.replace(at, own.size(), "<partition>*.a*</partition>");  // widen the grant without re-signing
  std::ofstream(copy / "agent-1" / "permissions.p7s") << text;
  const auto result = run_command("timeout 60 " + kBinary + " agent --scenario " + kScenario + " --id 1" +
                                  world_flags(54) + " --set dds.run_id=tamper --security " + copy.string());
  EXPECT_EQ(result.exit_code, 1) << result.output;  // participant creation fails: a runtime failure
  EXPECT_NE(result.output.find("runtime failure"), std::string::npos) << result.output;
}

TEST(Security, SecuredRunConvergesAndRoguesNeitherReceiveNorInject) {
  const auto& p = pki();
  // (1) Reference: no security, no rogue.
  const auto plain = run_dds(fresh_directory("sec-plain"), "", 50);

  // (2) Control: no security, a rogue with no security claiming agent kRogueId. Its samples reach the
  //     honest agents (and are rejected there), and it receives START — the set-up lets rogues in.
  //     Free run: the control needs only the rogue's samples to arrive, not a lockstep barrier that a
  //     duplicate agent kRogueId could disturb.
  const auto control_dir = fresh_directory("sec-control");
  Rogue open_rogue(control_dir, "rogue-open", "", kAgents + 1, 51, "free_run");
  const auto control = run_dds(control_dir, "", 51, "free_run");
  const auto open_log = open_rogue.stop();
  EXPECT_GT(rejected_total(control), 0) << "control: the rogue's samples did not reach the honest agents";
  EXPECT_NE(open_log.find("START received"), std::string::npos) << open_log;
  EXPECT_GT(max_matched(open_log), 0) << open_log;

  // (3) Secured run with two rogues: a certificate from another CA, and no security at all.
  const auto secured_dir = fresh_directory("sec-secured");
  Rogue foreign(secured_dir, "rogue-foreign-ca", " --security " + p.foreign.string(), kAgents + 1, 52);
  Rogue unauthenticated(secured_dir, "rogue-no-cert", "", kAgents + 2, 52);
  const auto secured = run_dds(secured_dir, " --security " + p.honest.string(), 52);
  const auto foreign_log = foreign.stop();
  const auto unauthenticated_log = unauthenticated.stop();

  const double plain_rmse = plain["final"]["rmse_m"];
  const double secured_rmse = secured["final"]["rmse_m"];
  const double range_std = 0.1;  // noise.range_std_m of scenarios/ieif.yaml
  EXPECT_LT(secured_rmse, range_std);
  EXPECT_LT(plain_rmse, range_std);
  EXPECT_NEAR(secured_rmse, plain_rmse, 1e-9) << "the rogues changed the honest estimates";
  EXPECT_EQ(secured["final"]["scored_agents"], plain["final"]["scored_agents"]);
  // Nothing the rogues published reached an honest agent or the orchestrator …
  EXPECT_EQ(rejected_total(secured), 0) << secured["rejected_by_reason"].dump();
  EXPECT_EQ(secured["rejected_reports"].get<long>(), 0);
  // … and the rogues matched no honest writer and never received the orchestrator's START.
  for (const auto* log : {&foreign_log, &unauthenticated_log}) {
    EXPECT_EQ(log->find("START received"), std::string::npos) << *log;
    EXPECT_EQ(max_matched(*log), 0) << *log;
  }
  std::printf(
      "[ figures  ] final RMSE: plain %.4f m, secured %.4f m; control run: %ld rogue samples rejected\n",
      plain_rmse, secured_rmse, rejected_total(control));
  std::printf("[ figures  ] wall_s plain %s secured %s; cpu_per_agent_s plain %s secured %s\n",
              plain["wall_s"].dump().c_str(), secured["wall_s"].dump().c_str(),
              plain["cpu_per_agent_s"].dump().c_str(), secured["cpu_per_agent_s"].dump().c_str());
}

}  // namespace
}  // namespace security_dds_test
