#!/usr/bin/env bash
# Runs the Kubernetes manifests of this directory with `podman kube play` (no cluster needed).
#
#   sudo deploy/k8s/podman-play.sh            # create and run: the orchestrator Job's pod + N agent pods
#   sudo deploy/k8s/podman-play.sh --dry      # only parse and create the pods (--start=false), then remove
#
# podman 4.3 (Debian bookworm) plays Pods, Deployments and ConfigMaps, not StatefulSets, Jobs or
# Services. So the script expands the StatefulSet's pod template into one Pod per ordinal
# (name and hostname swarmloc-agent-<i>, as Kubernetes names them) and the Job's template into one Pod,
# unchanged otherwise (image, command, args, env, volumes, resources, hostname); configmap.yaml is
# passed with --configmap. The pods discover each other by unicast only (unicast-peers.sh in
# configmap.yaml: AllowMulticast false in every participant, Peers = the pods' names under the headless
# Service swarmloc-agents), so the script has to make <pod>.swarmloc-agents resolve as the Service's
# DNS would:
#   RESOLVE=dns    (default) a podman bridge network with DNS (CNI backend + the dnsname plugin,
#                  Debian: golang-github-containernetworking-plugin-dnsname), its dnsmasq domain set to
#                  the Service's name, so every pod resolves <pod>.swarmloc-agents through DNS. dnsname
#                  does not work on --internal networks, so this bridge has NAT to the outside.
#   RESOLVE=hosts  an --internal bridge (no NAT, no DNS), a static IP per pod (--ip) and the names as
#                  hostAliases (/etc/hosts) in every pod.
# Needs the image localhost/swarmloc:latest (deploy/container/README.md), podman, runc and python3-yaml.
# Environment:
#   OUT      where the generated pods.yaml and the logs go (default: a new mktemp -d)
#   NETWORK  podman network name (default swarmloc-k8s-$$; created and removed here)
#   DOMAIN   replaces dds.domain_id of the ConfigMap's scenario (default: keep it)
#   SCENARIO_SETS  more of the ConfigMap scenario's keys to replace, as KEY=VALUE words, e.g.
#            "run.mode=lockstep run.steps=150" (VALUE parsed as YAML; CI compares a lockstep run with the
#            same scenario run as processes)
#   IMAGE    replaces every container's image (default: keep the manifests' localhost/swarmloc:latest)
#   RESOLVE  dns (default) or hosts, above
#   BLOCK_MULTICAST=1  also drop every IPv4 multicast frame the network's bridge would forward between
#            pods (an nftables bridge-family table, removed at the end; needs nft) and print how many
#            were dropped and how many other frames were forwarded: proof that discovery is unicast
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
dry=0
[[ "${1:-}" == "--dry" ]] && dry=1
out="${OUT:-$(mktemp -d /tmp/swarmloc-k8s-XXXXXX)}"
network="${NETWORK:-swarmloc-k8s-$$}"
resolve="${RESOLVE:-dns}"
[[ "$resolve" == dns || "$resolve" == hosts ]] || { echo "podman-play: RESOLVE=dns or hosts" >&2; exit 2; }

# shellcheck disable=SC2317  # called by the EXIT trap
cleanup() {
  if [[ -f "$out/pods.yaml" ]]; then podman kube down "$out/pods.yaml" >/dev/null 2>&1 || true; fi
  podman network rm -f "$network" >/dev/null 2>&1 || true
  if [[ -n "${nft_table:-}" ]]; then nft delete table bridge "$nft_table" 2>/dev/null || true; fi
}
trap cleanup EXIT
service=$(python3 -c 'import sys, yaml; print(yaml.safe_load(open(sys.argv[1]))["metadata"]["name"])' \
  "$here/service.yaml")
if [[ "$resolve" == dns ]]; then
  podman network create "$network" >/dev/null
  conflist="/etc/cni/net.d/$network.conflist"
  if [[ "$(podman network inspect --format '{{.DNSEnabled}}' "$network")" != true || ! -f "$conflist" ]]; then
    echo "podman-play: network $network has no DNS (needs the CNI backend and the dnsname plugin); RESOLVE=hosts works without" >&2
    exit 1
  fi
  # dnsname's dnsmasq answers <container or pod name>.<domainName>; make that the Service's name.
  sed -i "s/\"domainName\": \"[^\"]*\"/\"domainName\": \"$service\"/" "$conflist"
  subnet=""
else
  podman network create --internal "$network" >/dev/null
  subnet=$(podman network inspect --format '{{range .Subnets}}{{.Subnet}} {{end}}' "$network" | awk '{print $1}')
fi
if [[ "${BLOCK_MULTICAST:-0}" == 1 ]]; then
  # By the network's (unique) subnet: this nft build lacks `meta ibrname`.
  net_subnet=$(podman network inspect --format '{{range .Subnets}}{{.Subnet}} {{end}}' "$network" | awk '{print $1}')
  nft_table="swarmloc_k8s_$$"
  nft -f - <<NFT
table bridge $nft_table {
  chain forward {
    type filter hook forward priority 0; policy accept;
    ip saddr $net_subnet ip daddr 224.0.0.0/4 counter drop comment "multicast"
    ip saddr $net_subnet counter comment "other"
  }
}
NFT
fi

# On hosts without CAP_SYS_RESOURCE (this one: hard nofile limit 20000) runc cannot raise the
# containers' limits to podman's defaults; modest ones work (deploy/container/README.md).
printf '[containers]\ndefault_ulimits = ["nofile=1024:1024", "nproc=4096:4096"]\n' >"$out/containers.conf"
export CONTAINERS_CONF="$out/containers.conf"

python3 - "$here" "$out" "${DOMAIN:-}" "$service" "$subnet" "${IMAGE:-}" "${SCENARIO_SETS:-}" <<'EOF'
import copy, ipaddress, sys, yaml
here, out, domain, service, subnet, image, scenario_sets = sys.argv[1:8]
target = f"{out}/pods.yaml"
load = lambda name: yaml.safe_load(open(f"{here}/{name}"))
statefulset, job = load("agents-statefulset.yaml"), load("orchestrator-job.yaml")
configmap = load("configmap.yaml")
scenario = yaml.safe_load(configmap["data"]["scenario.yaml"])
agents = scenario["world"]["agents"]
if domain:
    scenario["dds"]["domain_id"] = int(domain)
for assignment in scenario_sets.split():
    key, _, value = assignment.partition("=")
    *path, leaf = key.split(".")
    node = scenario
    for part in path:
        node = node.setdefault(part, {})
    node[leaf] = yaml.safe_load(value)
if domain or scenario_sets:
    configmap["data"]["scenario.yaml"] = yaml.safe_dump(scenario, sort_keys=False)
with open(f"{out}/configmap.yaml", "w") as f:
    yaml.safe_dump(configmap, f, sort_keys=False)
replicas = statefulset["spec"]["replicas"]
if replicas != agents:
    sys.exit(f"podman-play: StatefulSet replicas {replicas} != world.agents {agents} in configmap.yaml")

def pod(name, template):
    spec = copy.deepcopy(template["spec"])
    # A StatefulSet pod's hostname is its name (the agent id is the ordinal); the Job's template sets
    # hostname swarmloc-orchestrator itself.
    spec.setdefault("hostname", name)
    spec.pop("subdomain", None)  # the Service's DNS is the network's (RESOLVE) here
    if image:
        for container in spec["containers"]:
            container["image"] = image
    return {"apiVersion": "v1", "kind": "Pod",
            "metadata": {"name": name, "labels": template["metadata"]["labels"]}, "spec": spec}

pods = [pod("swarmloc-orchestrator", job["spec"]["template"])]
pods += [pod(f"{statefulset['metadata']['name']}-{i}", statefulset["spec"]["template"]) for i in range(replicas)]
if subnet:  # RESOLVE=hosts: static IPs (in pod order, --ip) and every name in every pod's /etc/hosts
    hosts = list(ipaddress.ip_network(subnet).hosts())[9:9 + len(pods)]
    aliases = [{"ip": str(ip), "hostnames": [f"{p['spec']['hostname']}.{service}"]} for ip, p in zip(hosts, pods)]
    for p in pods:
        p["spec"]["hostAliases"] = aliases
    with open(f"{out}/ips", "w") as f:
        f.write(" ".join(str(ip) for ip in hosts) + "\n")
with open(target, "w") as f:
    yaml.safe_dump_all(pods, f, sort_keys=False)
print(f"podman-play: {len(pods)} pods (1 orchestrator, {replicas} agents) -> {target}; peers *.{service}")
EOF

ip_args=()
if [[ -f "$out/ips" ]]; then
  read -ra ips <"$out/ips"
  for ip in "${ips[@]}"; do ip_args+=(--ip "$ip"); done
fi

if ((dry)); then
  podman kube play --start=false --network "$network" "${ip_args[@]}" --configmap "$out/configmap.yaml" "$out/pods.yaml"
  podman pod ps --filter "name=swarmloc" --format '{{.Name}} {{.Status}} {{.NumberOfContainers}}'
  echo "podman-play: created, not started (--dry)"
  exit 0
fi

started=$(date +%s)
podman kube play --network "$network" "${ip_args[@]}" --configmap "$out/configmap.yaml" "$out/pods.yaml" \
  >"$out/play.log" 2>&1 || { tail -n 20 "$out/play.log" >&2; exit 1; }
# The Job's container: podman names it <pod>-<container>.
rc=$(podman wait swarmloc-orchestrator-orchestrator)
podman logs swarmloc-orchestrator-orchestrator >"$out/orchestrator.log" 2>&1
for pod in $(podman pod ps --filter name=swarmloc-agent --format '{{.Name}}'); do
  podman logs "$pod-agent" >"$out/$pod.log" 2>&1 || true
done
echo "podman-play: orchestrator exited with $rc after $(($(date +%s) - started)) s; logs in $out"
# Each pod's first line (an agent pod restarted after STOP logs it again).
mapfile -t agent_logs < <(printf '%s\n' "$out"/swarmloc-agent-*.log | sort -V)
for log in "$out/orchestrator.log" "${agent_logs[@]}"; do grep -m1 -h '^unicast-peers: ' "$log" || true; done
# "HH:MM:SS.mmm info all N agents reporting after S s; START" (UTC, the host's clock)
if reporting=$(grep -m1 -o '^[0-9:.]* info all [0-9]* agents reporting' "$out/orchestrator.log"); then
  at=$(date -u -d "$(date -u -d "@$started" +%F) ${reporting%% *}" +%s.%N)
  awk -v at="$at" -v started="$started" \
    'BEGIN { printf "podman-play: all agents reporting %.1f s after kube play started\n", at - started }'
fi
if [[ -n "${nft_table:-}" ]]; then
  nft list table bridge "$nft_table" | sed -n 's/.*counter packets \([0-9]*\) bytes [0-9]* \(drop \)\?comment "\(.*\)"/\3 \1/p' |
    tr '\n' ' ' | sed 's/^/podman-play: IPv4 frames forwarded between pods: /; s/$/(multicast ones dropped)\n/'
fi
tail -n 40 "$out/orchestrator.log"
exit "$rc"
