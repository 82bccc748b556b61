#!/usr/bin/env bash
# multihost.sh SWARMLOC_BINARY OUT_DIR [LOSS_PERCENT] [-- EXTRA swarmloc --set ARGS...]
#
# Runs swarmloc across several "machines" on one Linux host: network namespaces joined by a bridge
# (deploy/README.md, "Running across machines"; reference: docs/measurements/feasibility.md §1).
#
#   <prefix>sw   switch namespace: bridge br0 with ports v0..v3, optional nftables loss rule
#   <prefix>h0   10.77.0.10  orchestrator (`swarmloc run --no-launch`)
#   <prefix>h1.. 10.77.0.11+ the agents, round-robin (`swarmloc agent` as plain processes)
#
# SWARMLOC_MULTIHOST_IMAGE=IMAGE runs the agents of the last host as podman containers of IMAGE joined
# to that host's namespace (`podman run --network ns:/run/netns/<host>`), the others stay processes.
# IMAGE must contain this build (deploy/k8s/Containerfile.host-binary wraps a host build in a minute):
# the agents take their manifest and the run's scenario from the orchestrator over DDS (`swarmloc agent
# --id N`, no scenario file, no world), and an older binary may not know its keys.
#
# Cyclone uses SPDP multicast on eth0 (dds.neighbour_discovery=false): neighbour discovery assumes
# every peer at one address and does not work across hosts. LOSS_PERCENT (default 0) drops that
# share of UDP frames (both directions, discovery included) in the bridge's forward hook, in the
# switch namespace, so it is real wire loss rather than EPERM on the sender (docs/measurements/feasibility.md §1, pitfall).
#
# SWARMLOC_MULTIHOST_LINK=wifi replaces the bridge by deploy/netns/wifi-switch.c, a userspace switch
# whose every link delays each frame by SWARMLOC_MULTIHOST_DELAY_MS (default 20) plus a uniform jitter
# of +-SWARMLOC_MULTIHOST_JITTER_MS (default 10) and loses LOSS_PERCENT of them (per link crossed), and
# drops every IPv4 multicast frame: discovery is then unicast only. The switch binary is
# SWARMLOC_MULTIHOST_SWITCH, or compiled here from the source with cc. It turns checksum offload off on
# each host's eth0 (ethtool): frames with partial checksums do not survive a userspace forwarder.
# SWARMLOC_MULTIHOST_UNICAST (default: neighbours with wifi, off on the bridge) turns multicast off and
# gives every process unicast Peers (deploy/README.md, "Many robots over WiFi"):
#   neighbours  swarmloc's own neighbour discovery (dds.neighbour_discovery: fixed ParticipantIndex per
#               agent, AllowMulticast false), with dds.peer_address this host's address, and the Peers
#               it cannot know appended in SWARMLOC_CYCLONE_URI_EXTRA: each neighbour (from the
#               orchestrator's manifests/agent_<id>.json) and the orchestrator at their own host's
#               address and fixed discovery port; the orchestrator lists every agent so.
#   hosts       all-to-all: ParticipantIndex auto, MaxAutoParticipantIndex above the processes per host
#               (Cyclone's default, 9, allows 10), one Peer per host (every index on it). Measured: 60
#               agents over the wifi links did not get through discovery (deploy/README.md).
#
# Namespaces are named slm<PID>..., so parallel or crashed runs never collide; everything created here
# (namespaces, every process inside them) is removed on exit, also on error or Ctrl-C.
# Needs root, iproute2 and (for loss > 0) nftables. Prints the final RMSE; exit code = the orchestrator's.
set -euo pipefail

usage() { echo "usage: $0 SWARMLOC_BINARY OUT_DIR [LOSS_PERCENT] [-- EXTRA_SWARMLOC_ARGS...]" >&2; exit 2; }
[ $# -ge 2 ] || usage
BIN=$(readlink -f "$1")
OUT=$2
LOSS=${3:-0}
shift $(( $# >= 3 ? 3 : 2 ))
if [ "${1:-}" = "--" ]; then shift; fi
EXTRA=("$@")

HOSTS=${SWARMLOC_MULTIHOST_HOSTS:-3}           # agent hosts (plus one orchestrator host)
LINK=${SWARMLOC_MULTIHOST_LINK:-bridge}         # bridge | wifi
DELAY_MS=${SWARMLOC_MULTIHOST_DELAY_MS:-20}     # wifi: one-way delay per link crossed
JITTER_MS=${SWARMLOC_MULTIHOST_JITTER_MS:-10}   # wifi: +- uniform jitter
SWITCH=${SWARMLOC_MULTIHOST_SWITCH:-}           # wifi: the wifi-switch binary (default: compiled here)
MANIFEST_TIMEOUT=${SWARMLOC_MULTIHOST_MANIFEST_TIMEOUT:-60}  # agents: seconds to wait for the orchestrator
UNICAST=${SWARMLOC_MULTIHOST_UNICAST:-$([ "$LINK" = wifi ] && echo neighbours || echo off)}
IMAGE=${SWARMLOC_MULTIHOST_IMAGE:-}             # agents of the last host as podman containers
SCENARIO=$(readlink -f "${SWARMLOC_MULTIHOST_SCENARIO:-$(dirname "$(readlink -f "$0")")/../../scenarios/default.yaml}")
[ -x "$BIN" ] || { echo "multihost: $BIN is not executable" >&2; exit 2; }
[[ "$LOSS" =~ ^[0-9]+$ ]] && [ "$LOSS" -le 100 ] || { echo "multihost: loss percent must be 0..100" >&2; exit 2; }
[ "$(id -u)" -eq 0 ] || { echo "multihost: needs root (ip netns)" >&2; exit 2; }
command -v ip >/dev/null || { echo "multihost: needs iproute2 (ip)" >&2; exit 2; }
[[ "$UNICAST" =~ ^(off|neighbours|hosts)$ ]] || { echo "multihost: SWARMLOC_MULTIHOST_UNICAST is off, neighbours or hosts" >&2; exit 2; }
[ "$LINK" = bridge ] || [ "$LINK" = wifi ] || { echo "multihost: SWARMLOC_MULTIHOST_LINK is bridge or wifi" >&2; exit 2; }
if [ "$LINK" = bridge ] && [ "$LOSS" -gt 0 ]; then
  command -v nft >/dev/null || { echo "multihost: needs nftables (nft) for loss" >&2; exit 2; }
fi
if [ "$LINK" = wifi ]; then
  command -v ethtool >/dev/null || { echo "multihost: the wifi link needs ethtool" >&2; exit 2; }
  if [ -z "$SWITCH" ]; then
    command -v cc >/dev/null || { echo "multihost: no SWARMLOC_MULTIHOST_SWITCH and no cc to build it" >&2; exit 2; }
  else
    SWITCH=$(readlink -f "$SWITCH")
    [ -x "$SWITCH" ] || { echo "multihost: $SWITCH is not executable" >&2; exit 2; }
  fi
fi
if [ -n "$IMAGE" ]; then
  command -v podman >/dev/null || { echo "multihost: SWARMLOC_MULTIHOST_IMAGE needs podman" >&2; exit 2; }
  podman image exists "$IMAGE" || { echo "multihost: no podman image $IMAGE" >&2; exit 2; }
fi

# A short run by default; EXTRA arguments come after these and override them.
SETS=(--set world.agents=20 --set world.anchors=6 --set world.area_m=35 --set run.steps=150
      --set run.rate_hz=10 --set run.startup_timeout_s=40
      --set dds.neighbour_discovery=false --set dds.interface=eth0)
SETS+=("${EXTRA[@]}")

# Re-announce participants every second (Cyclone default: 30 s): a lost multicast SPDP otherwise
# delays discovery by many seconds, and an agent that waits more than 5 s for START exits at START
# (agent_node.cpp starts its "orchestrator gone" timer at process start).
export SWARMLOC_CYCLONE_URI_EXTRA="<Discovery><SPDPInterval>1s</SPDPInterval></Discovery>${SWARMLOC_CYCLONE_URI_EXTRA:+,$SWARMLOC_CYCLONE_URI_EXTRA}"

SWITCH_PID=
P=slm$$
SW=${P}sw
NS=()
for ((k = 0; k <= HOSTS; ++k)); do NS+=("${P}h$k"); done
ORCH_PID=
CREATED=()

cleanup() {
  local rc=$?
  trap - EXIT INT TERM
  # Every process still inside one of our namespaces (agents, a hung orchestrator): TERM, then KILL.
  for sig in TERM KILL; do
    for ns in "${CREATED[@]}"; do
      pids=$(ip netns pids "$ns" 2>/dev/null || true)
      [ -n "$pids" ] && kill -s "$sig" $pids 2>/dev/null || true
    done
    [ "$sig" = TERM ] && sleep 1
  done
  [ -n "$ORCH_PID" ] && kill -KILL "$ORCH_PID" 2>/dev/null || true
  [ -n "$SWITCH_PID" ] && kill -KILL "$SWITCH_PID" 2>/dev/null || true
  if [ -n "$IMAGE" ]; then
    podman ps -a --format '{{.Names}}' 2>/dev/null | grep "^${P}a" | xargs -r podman rm -f >/dev/null 2>&1 || true
  fi
  for ns in "${CREATED[@]}"; do ip netns del "$ns" 2>/dev/null || true; done
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

mkns() { ip netns add "$1"; CREATED+=("$1"); ip -n "$1" link set lo up; }

# --- topology ------------------------------------------------------------------------------------
mkns "$SW"
ip -n "$SW" link add br0 type bridge
ip -n "$SW" link set br0 up
for ((k = 0; k <= HOSTS; ++k)); do
  mkns "${NS[k]}"
  ip -n "$SW" link add "v$k" type veth peer name eth0 netns "${NS[k]}"
  [ "$LINK" = bridge ] && ip -n "$SW" link set "v$k" master br0
  ip -n "$SW" link set "v$k" up
  ip -n "${NS[k]}" addr add "10.77.0.$((10 + k))/24" dev eth0
  ip -n "${NS[k]}" link set eth0 up
done
if [ "$LINK" = bridge ] && [ "$LOSS" -gt 0 ]; then
  ip netns exec "$SW" nft add table bridge slmloss
  ip netns exec "$SW" nft add chain bridge slmloss linkfwd '{ type filter hook forward priority 0; policy accept; }'
  ip netns exec "$SW" nft add rule bridge slmloss linkfwd meta l4proto udp numgen random mod 100 lt "$LOSS" counter drop
fi

# --- run -----------------------------------------------------------------------------------------
rm -rf "$OUT"
mkdir -p "$OUT"
OUT=$(readlink -f "$OUT")
# Beside the run directory, not in it: the orchestrator takes only an empty --out (docs/robustness.md).
LOGS=$OUT.host-logs
rm -rf "$LOGS"
mkdir -p "$LOGS"

if [ "$LINK" = wifi ]; then
  if [ -z "$SWITCH" ]; then
    SWITCH=$LOGS/wifi-switch
    cc -O2 -o "$SWITCH" "$(dirname "$(readlink -f "$0")")/wifi-switch.c"
  fi
  for ((k = 0; k <= HOSTS; ++k)); do
    ip netns exec "${NS[k]}" ethtool -K eth0 tx off sg off tso off gso off >/dev/null 2>&1 || true
  done
  PORTS=()
  for ((k = 0; k <= HOSTS; ++k)); do PORTS+=("v$k"); done
  ip netns exec "$SW" "$SWITCH" "$DELAY_MS" "$JITTER_MS" "$LOSS" "$$" "${PORTS[@]}" >"$LOGS/switch.log" 2>&1 &
  SWITCH_PID=$!
  LINK_DESC="wifi links ${DELAY_MS} ms +- ${JITTER_MS} ms, loss ${LOSS}% per link, multicast dropped"
else
  LINK_DESC="bridge, loss ${LOSS}%"
fi
if [ "$UNICAST" = hosts ]; then
  # Unicast discovery only. Every process lists every host; a Peer without a port stands for the
  # discovery ports of participant indices 0..MaxAutoParticipantIndex on it, and ParticipantIndex auto
  # takes the lowest free index on this host, so the limit must exceed the processes on one host
  # (Cyclone's default, 9, allows 10).
  per_host=20  # the default --set world.agents above
  for arg in "${EXTRA[@]}"; do [[ "$arg" =~ ^world\.agents=([0-9]+)$ ]] && per_host=${BASH_REMATCH[1]}; done
  MAX_INDEX=$(( (per_host + HOSTS - 1) / HOSTS + 2 ))
  PEERS=""
  # shellcheck disable=SC2089  # the quotes are XML's
  for ((k = 0; k <= HOSTS; ++k)); do PEERS+="<Peer address='10.77.0.$((10 + k))'/>"; done
  SWARMLOC_CYCLONE_URI_EXTRA+=",<General><AllowMulticast>false</AllowMulticast></General>"
  SWARMLOC_CYCLONE_URI_EXTRA+="<Discovery><ParticipantIndex>auto</ParticipantIndex>"
  SWARMLOC_CYCLONE_URI_EXTRA+="<MaxAutoParticipantIndex>$MAX_INDEX</MaxAutoParticipantIndex><Peers>$PEERS</Peers></Discovery>"
  # shellcheck disable=SC2090
  export SWARMLOC_CYCLONE_URI_EXTRA
  LINK_DESC+=", unicast discovery to every host (MaxAutoParticipantIndex $MAX_INDEX)"
elif [ "$UNICAST" = neighbours ]; then
  SETS+=(--set dds.neighbour_discovery=true)
  LINK_DESC+=", unicast discovery of neighbours"
fi
echo "multihost: $HOSTS agent hosts + orchestrator host (namespaces ${P}*), $LINK_DESC, out $OUT"

host_of() { echo $((1 + $1 % HOSTS)); }
address_of_host() { echo "10.77.0.$((10 + $1))"; }
# Cyclone's discovery port of swarmloc slot S (an agent id; the orchestrator's slot is the agent count)
# in domain D with neighbour discovery (common/dds/src/cyclone_config.cpp).
discovery_port() { echo $((7400 + 200 * ($1 / 100) + 250 * $2 + 10 + 2 * ($1 % 100))); }
peer() { echo "<Peer address='$1:$2'/>"; }

ORCH_SETS=()
if [ "$UNICAST" = neighbours ]; then ORCH_SETS=(--set "dds.peer_address=$(address_of_host 0)"); fi
ip netns exec "${NS[0]}" "$BIN" run "$SCENARIO" --no-launch -q --out "$OUT" "${SETS[@]}" "${ORCH_SETS[@]}" \
  >"$LOGS/orchestrator.log" 2>&1 &
ORCH_PID=$!

# The orchestrator writes the resolved scenario (every default, the seed) before it waits for agents.
for _ in $(seq 100); do
  [ -s "$OUT/scenario.yaml" ] && break
  kill -0 "$ORCH_PID" 2>/dev/null || break
  sleep 0.1
done
if [ ! -s "$OUT/scenario.yaml" ]; then
  echo "multihost: orchestrator did not start:" >&2
  cat "$LOGS/orchestrator.log" >&2
  rc=0
  kill -0 "$ORCH_PID" 2>/dev/null || { wait "$ORCH_PID" || rc=$?; ORCH_PID=; }
  exit $(( rc ? rc : 1 ))
fi
AGENTS=$(sed -n 's/^  agents: *\([0-9]*\).*/\1/p' "$OUT/scenario.yaml" | head -1)
[ -n "$AGENTS" ] || { echo "multihost: cannot read world.agents from $OUT/scenario.yaml" >&2; exit 1; }

# neighbours: each agent's Peers from its manifest (written before the orchestrator waits for agents).
neighbour_peers() { :; }
if [ "$UNICAST" = neighbours ]; then
  DOMAIN=$(sed -n 's/^  domain_id: *\([0-9]*\).*/\1/p' "$OUT/scenario.yaml" | head -1)
  last_manifest=$(printf '%s/manifests/agent_%03d.json' "$OUT" $((AGENTS - 1)))
  for _ in $(seq 100); do [ -s "$last_manifest" ] && break; sleep 0.1; done
  [ -s "$last_manifest" ] || { echo "multihost: no manifests in $OUT/manifests" >&2; exit 1; }
  neighbour_peers() {  # agent id -> its Peers: neighbours and the orchestrator, each at its host
    local manifest j list=""
    manifest=$(printf '%s/manifests/agent_%03d.json' "$OUT" "$1")
    for j in $(tr -d ' \n' <"$manifest" | grep -o '"neighbours":\[[0-9,]*\]' | grep -o '[0-9][0-9]*'); do
      list+=$(peer "$(address_of_host "$(host_of "$j")")" "$(discovery_port "$j" "$DOMAIN")")
    done
    echo "$list$(peer "$(address_of_host 0)" "$(discovery_port "$AGENTS" "$DOMAIN")")"
  }
  # The orchestrator, started before the agents' hosts were known, learns them from the agents' SPDP
  # (each lists it); Cyclone answers an unknown participant's SPDP directly.
fi

CONTAINERS=0
for ((i = 0; i < AGENTS; ++i)); do
  k=$(host_of "$i")
  host=${NS[k]}
  AGENT_EXTRA=$SWARMLOC_CYCLONE_URI_EXTRA
  AGENT_SETS=()
  if [ "$UNICAST" = neighbours ]; then
    AGENT_EXTRA+=",<Discovery><Peers>$(neighbour_peers "$i")</Peers></Discovery>"
    AGENT_SETS=(--set "dds.peer_address=$(address_of_host "$k")")
  fi
  if [ -n "$IMAGE" ] && [ "$k" -eq "$HOSTS" ]; then
    # The run directory is mounted at the same path, so the scenario and log paths stay valid.
    # Explicit rlimits: in this sandbox runc cannot raise them to podman's defaults (no CAP_SYS_RESOURCE;
    # docs/measurements/feasibility.md §2).
    podman run --rm --name "${P}a$i" --network "ns:/run/netns/$host" -v "$OUT:$OUT" -v "$LOGS:$LOGS" \
      --ulimit nofile=1024:1024 --ulimit nproc=1024:1024 \
      -e SWARMLOC_CYCLONE_URI_EXTRA="$AGENT_EXTRA" "$IMAGE" agent --id "$i" "${SETS[@]}" "${AGENT_SETS[@]}" \
      --manifest-timeout "$MANIFEST_TIMEOUT" \
      --log "$LOGS/agent-$i.log" >"$LOGS/agent-$i.out" 2>&1 &
    CONTAINERS=$((CONTAINERS + 1))
  else
    # One OpenBLAS thread: its pool spins ~0.1 s of CPU per process start (orchestrator/launcher.cpp).
    OPENBLAS_NUM_THREADS=${OPENBLAS_NUM_THREADS:-1} SWARMLOC_CYCLONE_URI_EXTRA=$AGENT_EXTRA ip netns exec "$host" "$BIN" agent --id "$i" "${SETS[@]}" \
      "${AGENT_SETS[@]}" --manifest-timeout "$MANIFEST_TIMEOUT" \
      --log "$LOGS/agent-$i.log" >"$LOGS/agent-$i.out" 2>&1 &
  fi
done

rc=0
wait "$ORCH_PID" || rc=$?
ORCH_PID=
# Agents exit on STOP; give stragglers a moment before cleanup kills them.
for _ in $(seq 50); do
  left=0
  for ((k = 1; k <= HOSTS; ++k)); do [ -n "$(ip netns pids "${NS[k]}" 2>/dev/null)" ] && left=1; done
  [ "$left" -eq 0 ] && break
  sleep 0.1
done

if [ -n "$SWITCH_PID" ]; then
  kill -TERM "$SWITCH_PID" 2>/dev/null || true
  wait "$SWITCH_PID" 2>/dev/null || true
  SWITCH_PID=
  echo "multihost: $(grep -h '^wifi-switch: received' "$LOGS/switch.log" || echo "wifi-switch: no counters")"
fi
# "HH:MM:SS.mmm info all N agents reporting after S s; START": from the orchestrator's start.
if reporting=$(grep -m1 -o 'all [0-9]* agents reporting after [0-9.]* s' "$LOGS/orchestrator.log"); then
  echo "multihost: $reporting"
fi
if [ "$LINK" = bridge ] && [ "$LOSS" -gt 0 ]; then
  echo "multihost: switch drops: $(ip netns exec "$SW" nft list chain bridge slmloss linkfwd | grep -o 'packets [0-9]*')"
fi
# 3: completed but degraded (README, exit codes): the run directory is complete; pass it on.
if { [ "$rc" -ne 0 ] && [ "$rc" -ne 3 ]; } || [ ! -s "$OUT/summary.json" ]; then
  echo "multihost: orchestrator exit code $rc" >&2
  tail -20 "$LOGS/orchestrator.log" >&2 || true
  [ "$rc" -ne 0 ] || rc=1
  exit "$rc"
fi
# summary.json: "final": { "rmse_m": ... } -- read it without jq/python.
RMSE=$(tr -d ' \n' <"$OUT/summary.json" | grep -o '"final":{[^}]*' | grep -o '"rmse_m":[-0-9.eE+]*' | cut -d: -f2)
SCORED=$(tr -d " \n" <"$OUT/summary.json" | grep -o "\"scored_agents\":[0-9]*" | cut -d: -f2)
echo "multihost: final RMSE ${RMSE} m ($AGENTS agents over $HOSTS hosts, $CONTAINERS of them in podman containers, $LINK_DESC, ${SCORED} agents scored)"
exit "$rc"
