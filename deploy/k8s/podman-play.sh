#!/usr/bin/env bash
# Runs the Kubernetes manifests of this directory with `podman kube play` (no cluster needed).
#
#   sudo deploy/k8s/podman-play.sh            # create and run: the orchestrator Job's pod + N agent pods
#   sudo deploy/k8s/podman-play.sh --dry      # only parse and create the pods (--start=false), then remove
#
# podman 4.3 (Debian bookworm) plays Pods, Deployments and ConfigMaps, not StatefulSets, Jobs or
# Services. So the script expands the StatefulSet's pod template into one Pod per ordinal
# (name and hostname swarmloc-agent-<i>, as Kubernetes names them) and the Job's template into one Pod,
# unchanged otherwise (image, command, args, env, volumes, resources); configmap.yaml is passed with
# --configmap. The pods share a podman network that is --internal (a bridge without NAT or route out),
# which carries multicast between pods as a flat CNI would. Needs the image localhost/swarmloc:latest
# (deploy/container/README.md), podman, runc and python3-yaml. Environment:
#   OUT      where the generated pods.yaml and the logs go (default: a new mktemp -d)
#   NETWORK  podman network name (default swarmloc-k8s-$$; created and removed here)
#   DOMAIN   replaces dds.domain_id of the ConfigMap's scenario (default: keep it)
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
dry=0
[[ "${1:-}" == "--dry" ]] && dry=1
out="${OUT:-$(mktemp -d /tmp/swarmloc-k8s-XXXXXX)}"
network="${NETWORK:-swarmloc-k8s-$$}"

# On hosts without CAP_SYS_RESOURCE (this one: hard nofile limit 20000) runc cannot raise the
# containers' limits to podman's defaults; modest ones work (deploy/container/README.md).
printf '[containers]\ndefault_ulimits = ["nofile=1024:1024", "nproc=4096:4096"]\n' >"$out/containers.conf"
export CONTAINERS_CONF="$out/containers.conf"

python3 - "$here" "$out" "${DOMAIN:-}" <<'EOF'
import copy, sys, yaml
here, out, domain = sys.argv[1], sys.argv[2], sys.argv[3]
target = f"{out}/pods.yaml"
load = lambda name: yaml.safe_load(open(f"{here}/{name}"))
statefulset, job = load("agents-statefulset.yaml"), load("orchestrator-job.yaml")
configmap = load("configmap.yaml")
scenario = yaml.safe_load(configmap["data"]["scenario.yaml"])
agents = scenario["world"]["agents"]
if domain:
    scenario["dds"]["domain_id"] = int(domain)
    configmap["data"]["scenario.yaml"] = yaml.safe_dump(scenario, sort_keys=False)
with open(f"{out}/configmap.yaml", "w") as f:
    yaml.safe_dump(configmap, f, sort_keys=False)
replicas = statefulset["spec"]["replicas"]
if replicas != agents:
    sys.exit(f"podman-play: StatefulSet replicas {replicas} != world.agents {agents} in configmap.yaml")

def pod(name, template):
    spec = copy.deepcopy(template["spec"])
    spec["hostname"] = name  # a StatefulSet pod's hostname is its name; the agent id is the ordinal
    return {"apiVersion": "v1", "kind": "Pod",
            "metadata": {"name": name, "labels": template["metadata"]["labels"]}, "spec": spec}

pods = [pod("swarmloc-orchestrator", job["spec"]["template"])]
pods += [pod(f"{statefulset['metadata']['name']}-{i}", statefulset["spec"]["template"]) for i in range(replicas)]
with open(target, "w") as f:
    yaml.safe_dump_all(pods, f, sort_keys=False)
print(f"podman-play: {len(pods)} pods (1 orchestrator, {replicas} agents) -> {target}")
EOF

# shellcheck disable=SC2317  # called by the EXIT trap
cleanup() {
  podman kube down "$out/pods.yaml" >/dev/null 2>&1 || true
  podman network rm -f "$network" >/dev/null 2>&1 || true
}
trap cleanup EXIT
podman network create --internal "$network" >/dev/null

if ((dry)); then
  podman kube play --start=false --network "$network" --configmap "$out/configmap.yaml" "$out/pods.yaml"
  podman pod ps --filter "name=swarmloc" --format '{{.Name}} {{.Status}} {{.NumberOfContainers}}'
  echo "podman-play: created, not started (--dry)"
  exit 0
fi

started=$(date +%s)
podman kube play --network "$network" --configmap "$out/configmap.yaml" "$out/pods.yaml" >"$out/play.log"
# The Job's container: podman names it <pod>-<container>.
rc=$(podman wait swarmloc-orchestrator-orchestrator)
podman logs swarmloc-orchestrator-orchestrator >"$out/orchestrator.log" 2>&1
for pod in $(podman pod ps --filter name=swarmloc-agent --format '{{.Name}}'); do
  podman logs "$pod-agent" >"$out/$pod.log" 2>&1 || true
done
echo "podman-play: orchestrator exited with $rc after $(($(date +%s) - started)) s; logs in $out"
tail -n 40 "$out/orchestrator.log"
exit "$rc"
