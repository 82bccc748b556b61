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
IMAGE=${SWARMLOC_MULTIHOST_IMAGE:-}             # agents of the last host as podman containers
SCENARIO=$(readlink -f "${SWARMLOC_MULTIHOST_SCENARIO:-$(dirname "$(readlink -f "$0")")/../../scenarios/default.yaml}")
[ -x "$BIN" ] || { echo "multihost: $BIN is not executable" >&2; exit 2; }
[[ "$LOSS" =~ ^[0-9]+$ ]] && [ "$LOSS" -le 100 ] || { echo "multihost: loss percent must be 0..100" >&2; exit 2; }
[ "$(id -u)" -eq 0 ] || { echo "multihost: needs root (ip netns)" >&2; exit 2; }
command -v ip >/dev/null || { echo "multihost: needs iproute2 (ip)" >&2; exit 2; }
if [ "$LOSS" -gt 0 ]; then command -v nft >/dev/null || { echo "multihost: needs nftables (nft) for loss" >&2; exit 2; }; fi
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
  ip -n "$SW" link set "v$k" master br0
  ip -n "$SW" link set "v$k" up
  ip -n "${NS[k]}" addr add "10.77.0.$((10 + k))/24" dev eth0
  ip -n "${NS[k]}" link set eth0 up
done
if [ "$LOSS" -gt 0 ]; then
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
echo "multihost: $HOSTS agent hosts + orchestrator host (namespaces ${P}*), loss ${LOSS}%, out $OUT"

ip netns exec "${NS[0]}" "$BIN" run "$SCENARIO" --no-launch -q --out "$OUT" "${SETS[@]}" \
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

CONTAINERS=0
for ((i = 0; i < AGENTS; ++i)); do
  k=$((1 + i % HOSTS))
  host=${NS[k]}
  if [ -n "$IMAGE" ] && [ "$k" -eq "$HOSTS" ]; then
    # The run directory is mounted at the same path, so the scenario and log paths stay valid.
    # Explicit rlimits: in this sandbox runc cannot raise them to podman's defaults (no CAP_SYS_RESOURCE;
    # docs/measurements/feasibility.md §2).
    podman run --rm --name "${P}a$i" --network "ns:/run/netns/$host" -v "$OUT:$OUT" -v "$LOGS:$LOGS" \
      --ulimit nofile=1024:1024 --ulimit nproc=1024:1024 \
      -e SWARMLOC_CYCLONE_URI_EXTRA "$IMAGE" agent --id "$i" "${SETS[@]}" \
      --log "$LOGS/agent-$i.log" >"$LOGS/agent-$i.out" 2>&1 &
    CONTAINERS=$((CONTAINERS + 1))
  else
    # One OpenBLAS thread: its pool spins ~0.1 s of CPU per process start (orchestrator/launcher.cpp).
    OPENBLAS_NUM_THREADS=${OPENBLAS_NUM_THREADS:-1} ip netns exec "$host" "$BIN" agent --id "$i" "${SETS[@]}" \
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

if [ "$LOSS" -gt 0 ]; then
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
echo "multihost: final RMSE ${RMSE} m ($AGENTS agents over $HOSTS hosts, $CONTAINERS of them in podman containers, loss ${LOSS}%, ${SCORED} agents scored)"
exit "$rc"
