// The container deployments of deploy/ run for real: the Compose file (one orchestrator container and
// twelve agent containers under podman-compose) and the Kubernetes manifests (StatefulSet, Job,
// ConfigMap, headless Service, under `podman kube play` through deploy/k8s/podman-play.sh). Each run's
// results are read from the orchestrator container's own log (it prints summary.json), and its final
// RMSE is compared with the same scenario run as processes on loopback. Both runs are lockstep
// (docs/scenario.md, run.mode): a lockstep run's estimates are a function of the scenario alone, so
// "within 10 %" checks the deployment (world, manifests, loss, clocks, every agent present) rather
// than free-run scheduling, whose same-seed runs differ by up to 2x on a loaded machine.
// The manifests are also checked offline: `kubectl kustomize deploy/k8s` (or, without kubectl, the
// files kustomization.yaml lists), then that they agree with each other.
// Needs root, podman, podman-compose and SWARMLOC_TEST_PODMAN_IMAGE (scripts/test builds it); skipped
// without them, failed without them when SWARMLOC_TEST_REQUIRE_DEPLOYMENTS=1 (CI).
#include <gtest/gtest.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "deployment_helpers.hpp"
#include "process_helpers.hpp"

namespace deployments_test {
namespace {

using swarmloc::testing::completed_run;
using swarmloc::testing::fresh_directory;
using swarmloc::testing::last_json_object;
using swarmloc::testing::missing_podman_image;
using swarmloc::testing::podman_test_image;
using swarmloc::testing::read_json;
using swarmloc::testing::read_text;
using swarmloc::testing::run_command;
using swarmloc::testing::write_containers_conf;

const std::string kBinary = SWARMLOC_BINARY;
const std::string kSourceDir = SWARMLOC_SOURCE_DIR;
const std::string kCompose = kSourceDir + "/deploy/compose/compose.yaml";
const std::string kK8s = kSourceDir + "/deploy/k8s";
const std::string kDefaultScenario = kSourceDir + "/scenarios/default.yaml";

/// Runs `command` when destroyed: cleanup that happens on a failed assertion too.
class Cleanup {
 public:
  explicit Cleanup(std::string command) : command_(std::move(command)) {}
  Cleanup(const Cleanup&) = delete;
  Cleanup& operator=(const Cleanup&) = delete;
  ~Cleanup() { run_command(command_); }

 private:
  std::string command_;
};

/// The final RMSE of the same scenario run as processes on loopback (neighbour discovery, the default).
double processes_rmse(const std::string& scenario, const std::string& sets, const std::string& name) {
  const auto dir = fresh_directory(name);
  const auto run = run_command(kBinary + " run " + scenario + " -q --out " + dir.string() + sets);
  EXPECT_TRUE(completed_run(run.exit_code)) << run.output;
  if (!completed_run(run.exit_code)) return NAN;
  const auto summary = read_json(dir / "summary.json");
  EXPECT_EQ(summary["final"]["missing_agents"], 0);
  return summary["final"]["rmse_m"].get<double>();
}

int count_lines(const std::string& text) {
  int lines = 0;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines += line.empty() ? 0 : 1;
  return lines;
}

// ---- Kubernetes manifests, offline -----------------------------------------------------------------

/// The kustomization's objects: `kubectl kustomize` when kubectl is there, else its resources as files.
std::vector<YAML::Node> kustomized_objects(std::string& how) {
  std::vector<YAML::Node> objects;
  if (run_command("kubectl version --client").exit_code == 0) {
    const auto built = run_command("(kubectl kustomize " + kK8s + " 2>/dev/null)");
    EXPECT_EQ(built.exit_code, 0) << built.output;
    how = "kubectl kustomize";
    objects = YAML::LoadAll(built.output);
  } else {
    how = "kustomization.yaml's resources";
    for (const auto& resource : YAML::LoadFile(kK8s + "/kustomization.yaml")["resources"]) {
      for (const auto& doc : YAML::LoadAllFromFile(kK8s + "/" + resource.as<std::string>()))
        objects.push_back(doc);
    }
  }
  return objects;
}

YAML::Node only_of_kind(const std::vector<YAML::Node>& objects, const std::string& kind) {
  YAML::Node found;
  int count = 0;
  for (const auto& object : objects) {
    if (object["kind"] && object["kind"].as<std::string>() == kind) found = object, ++count;
  }
  EXPECT_EQ(count, 1) << "kind " << kind;
  return found;
}

/// Every label the selector asks for, with the same value, in `labels`.
bool selects(const YAML::Node& selector, const YAML::Node& labels) {
  for (const auto& entry : selector) {
    const auto key = entry.first.as<std::string>();
    if (!labels[key] || labels[key].as<std::string>() != entry.second.as<std::string>()) return false;
  }
  return selector.size() > 0;
}

/// The names of the ConfigMaps a pod template mounts.
std::set<std::string> mounted_configmaps(const YAML::Node& pod_spec) {
  std::set<std::string> names;
  for (const auto& volume : pod_spec["volumes"]) {
    if (volume["configMap"]) names.insert(volume["configMap"]["name"].as<std::string>());
  }
  return names;
}

TEST(Deployments, KubernetesManifestsBuildWithKustomizeAndAgreeWithEachOther) {
  std::string how;
  const auto objects = kustomized_objects(how);
  ASSERT_EQ(objects.size(), 4U) << "objects from " << how;
  const auto configmap = only_of_kind(objects, "ConfigMap");
  const auto service = only_of_kind(objects, "Service");
  const auto statefulset = only_of_kind(objects, "StatefulSet");
  const auto job = only_of_kind(objects, "Job");
  ASSERT_TRUE(configmap && service && statefulset && job) << how;

  const auto service_name = service["metadata"]["name"].as<std::string>();
  const auto configmap_name = configmap["metadata"]["name"].as<std::string>();
  // Headless, and names published before readiness: unicast-peers.sh resolves every pod by name.
  EXPECT_EQ(service["spec"]["clusterIP"].as<std::string>(), "None");
  EXPECT_TRUE(service["spec"]["publishNotReadyAddresses"].as<bool>());
  // The agents' and the orchestrator's DNS names live under the Service.
  EXPECT_EQ(statefulset["spec"]["serviceName"].as<std::string>(), service_name);
  const auto job_pod = job["spec"]["template"]["spec"];
  EXPECT_EQ(job_pod["subdomain"].as<std::string>(), service_name);
  EXPECT_EQ(job_pod["hostname"].as<std::string>(), "swarmloc-orchestrator");  // unicast-peers.sh lists it
  // The Service selects both kinds of pod; the StatefulSet's selector its own template.
  EXPECT_TRUE(selects(service["spec"]["selector"], statefulset["spec"]["template"]["metadata"]["labels"]));
  EXPECT_TRUE(selects(service["spec"]["selector"], job["spec"]["template"]["metadata"]["labels"]));
  EXPECT_TRUE(selects(statefulset["spec"]["selector"]["matchLabels"],
                      statefulset["spec"]["template"]["metadata"]["labels"]));
  // Both mount the ConfigMap, which holds the scenario and the discovery script.
  EXPECT_EQ(mounted_configmaps(statefulset["spec"]["template"]["spec"]),
            std::set<std::string>{configmap_name});
  EXPECT_EQ(mounted_configmaps(job_pod), std::set<std::string>{configmap_name});
  ASSERT_TRUE(configmap["data"]["unicast-peers.sh"]);
  // One agent pod per agent of the scenario, and the scenario parses as swarmloc's.
  const auto scenario = YAML::Load(configmap["data"]["scenario.yaml"].as<std::string>());
  EXPECT_EQ(statefulset["spec"]["replicas"].as<int>(), scenario["world"]["agents"].as<int>());
  EXPECT_FALSE(scenario["dds"]["neighbour_discovery"].as<bool>());
  const auto dir = fresh_directory("k8s-scenario");
  std::ofstream(dir / "scenario.yaml") << configmap["data"]["scenario.yaml"].as<std::string>();
  const auto check =
      run_command(kBinary + " sim " + (dir / "scenario.yaml").string() + " -q --set run.steps=2");
  EXPECT_EQ(check.exit_code, 0) << "the ConfigMap's scenario: " << check.output;
}

// ---- Compose ---------------------------------------------------------------------------------------

TEST(Deployments, ComposeTwelveAgentContainersWithTwentyPercentLossAndDriftMatchProcesses) {
  if (const auto why = missing_podman_image(); !why.empty()) SWARMLOC_SKIP_DEPLOYMENT(why);
  if (run_command("podman-compose --version").exit_code != 0)
    SWARMLOC_SKIP_DEPLOYMENT("needs podman-compose (scripts/install-deps.sh --test)");

  const auto dir = fresh_directory("compose");
  const std::string project = "slmc" + std::to_string(::getpid());
  const std::string orchestrator = project + "_orchestrator_1";
  // The results keys are the orchestrator's (RUN_SETS); the agents take them from their manifests.
  const std::string results = " --set network.loss=0.2 --set clock.drift_ppm=200 --set run.mode=lockstep";
  const std::string env = "AGENTS=12 ANCHORS=4 AREA_M=30 STEPS=150 DOMAIN=153 RUN_ID=" + project +
                          " SWARMLOC_IMAGE=" + podman_test_image() + " RUN_SETS='" + results +
                          "' CONTAINERS_CONF=" + write_containers_conf(dir) + " ";
  const std::string compose = env + "podman-compose -p " + project + " -f " + kCompose + " ";
  const Cleanup down(compose + "down -v >/dev/null 2>&1; podman network rm -f " + project +
                     "_dds >/dev/null 2>&1");

  const auto up = run_command(compose + "up -d");
  ASSERT_EQ(up.exit_code, 0) << up.output;
  const auto waited = run_command("timeout 400 podman wait " + orchestrator);
  const auto log = run_command("podman logs " + orchestrator).output;
  ASSERT_EQ(waited.exit_code, 0) << "orchestrator container: " << log;
  EXPECT_TRUE(completed_run(std::stoi(waited.output))) << log;

  // Twelve agent containers, each with its own id.
  const auto agents = run_command("podman ps -a --format '{{.Names}}' | grep -c '^" + project + "_agent_'");
  EXPECT_EQ(agents.output, "12\n");
  std::set<std::string> ids;
  for (int i = 1; i <= 12; ++i) {
    const auto agent_log = run_command("podman logs " + project + "_agent_" + std::to_string(i)).output;
    if (const auto at = agent_log.find("agent id "); at != std::string::npos)
      ids.insert(agent_log.substr(at + 9, agent_log.find('\n', at) - at - 9));
  }
  EXPECT_EQ(ids.size(), 12U) << "agent ids claimed";

  const auto summary = last_json_object(log);
  ASSERT_TRUE(summary.is_object()) << "no summary.json in the orchestrator container's log: " << log;
  EXPECT_EQ(summary["agents"], 12);
  EXPECT_EQ(summary["final"]["missing_agents"], 0);
  EXPECT_DOUBLE_EQ(summary["links"]["loss_probability"].get<double>(), 0.2);
  const double injected = summary["links"]["dropped_injected"].get<double>();
  const double sent = summary["links"]["sent"].get<double>();
  EXPECT_GT(injected, 0.1 * sent) << "20 % injected loss";
  EXPECT_LT(injected, 0.3 * sent) << "20 % injected loss";
  const double containers = summary["final"]["rmse_m"].get<double>();

  const double processes =
      processes_rmse(kDefaultScenario,
                     " --set world.agents=12 --set world.anchors=4 --set world.area_m=30"
                     " --set run.steps=150 --set run.rate_hz=10 --set dds.domain_id=221" +
                         results,
                     "compose-processes");
  EXPECT_LT(containers, 0.1) << "final RMSE below the range noise std";
  EXPECT_LE(std::abs(containers - processes), 0.1 * processes)
      << "compose " << containers << " m vs processes " << processes << " m";
  std::cout << "compose: final RMSE " << containers << " m (12 agent containers), processes " << processes
            << " m, ratio " << containers / processes << "\n";
}

// ---- Kubernetes manifests under podman kube play ---------------------------------------------------

TEST(Deployments, KubernetesManifestsUnderPodmanKubePlayMatchProcesses) {
  if (const auto why = missing_podman_image(); !why.empty()) SWARMLOC_SKIP_DEPLOYMENT(why);
  if (run_command("python3 -c 'import yaml'").exit_code != 0)
    SWARMLOC_SKIP_DEPLOYMENT("needs python3-yaml (scripts/install-deps.sh --test)");

  const auto dir = fresh_directory("k8s");
  const std::string network = "slmk" + std::to_string(::getpid());
  const Cleanup remove("podman kube down " + (dir / "pods.yaml").string() +
                       " >/dev/null 2>&1; podman network rm -f " + network + " >/dev/null 2>&1");
  const std::string steps = "150";
  const auto run =
      run_command("OUT=" + dir.string() + " NETWORK=" + network + " DOMAIN=155 IMAGE=" + podman_test_image() +
                  " BLOCK_MULTICAST=1 SCENARIO_SETS='run.mode=lockstep run.steps=" + steps +
                  "' timeout -k 10 500 bash " + kK8s + "/podman-play.sh");
  ASSERT_TRUE(completed_run(run.exit_code)) << run.output;
  // Discovery was unicast: the bridge dropped every multicast frame between the pods, and there were none.
  EXPECT_NE(run.output.find("IPv4 frames forwarded between pods: multicast 0 other "), std::string::npos)
      << run.output;
  const auto summary = last_json_object(read_text(dir / "orchestrator.log"));
  ASSERT_TRUE(summary.is_object()) << "no summary.json in the orchestrator container's log";
  EXPECT_EQ(summary["agents"], 12);
  EXPECT_EQ(summary["final"]["missing_agents"], 0);
  const double pods = summary["final"]["rmse_m"].get<double>();

  // The same scenario, the ConfigMap's own, as processes on loopback.
  const auto configmap = YAML::LoadFile(kK8s + "/configmap.yaml");
  std::ofstream(dir / "scenario.yaml") << configmap["data"]["scenario.yaml"].as<std::string>();
  const double processes = processes_rmse((dir / "scenario.yaml").string(),
                                          " --set run.mode=lockstep --set run.steps=" + steps +
                                              " --set dds.domain_id=222 --set dds.interface=lo"
                                              " --set dds.neighbour_discovery=true",
                                          "k8s-processes");
  EXPECT_LT(pods, 0.1) << "final RMSE below the range noise std";
  EXPECT_LE(std::abs(pods - processes), 0.1 * processes)
      << "kube play " << pods << " m vs processes " << processes;
  std::cout << "kube play: final RMSE " << pods << " m (12 agent pods), processes " << processes
            << " m, ratio " << pods / processes << "\n";

  // The script removed its pods and network.
  EXPECT_EQ(count_lines(run_command("podman pod ps --filter name=swarmloc- --format '{{.Name}}'").output), 0);
  EXPECT_NE(run_command("podman network exists " + network).exit_code, 0) << "network " << network << " left";
}

}  // namespace
}  // namespace deployments_test
