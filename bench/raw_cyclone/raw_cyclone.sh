#!/usr/bin/env bash
# Raw Cyclone DDS cost on this machine (docs/measurements/raw-cyclone.md): N raw_peer processes, each
# publishing one best-effort sample per 100 ms to its neighbours and counting its neighbours' samples,
# with the same per-process Cyclone configuration as the swarmloc agents (unicast discovery on lo, fixed
# ports, each peer listing exactly its neighbours as Peers).
#
# Usage: raw_cyclone.sh N DEGREE SECONDS [BYTES]
#   N peers at uniform random positions in the unit square; two peers are neighbours when closer than a
#   radius chosen so that the mean degree is DEGREE (a random geometric graph, like the agents' radio
#   range). The peers start writing at once; the measured window of SECONDS starts WARMUP seconds after
#   the launch (discovery), at the same wall-clock time for all. BYTES: payload size (default 200).
# Environment: RAW_CYCLONE_DOMAIN (222), RAW_CYCLONE_WARMUP (seconds, default 10 + N/20),
#   RAW_CYCLONE_SEED (positions, default 1), RAW_PEER (the binary, default build/bench/raw_cyclone/raw_peer),
#   RAW_CYCLONE_IDLE_WAIT (seconds to wait for an idle machine before launching, default 600),
#   RAW_CYCLONE_KEEP=1 keeps the work directory (XML, per-peer output).
# Run it under the DDS lock, one experiment at a time:
#   flock /work/.dds.lock bench/raw_cyclone/raw_cyclone.sh 400 12 20
set -euo pipefail

if [[ $# -lt 3 ]]; then
  sed -n '2,18p' "$0" >&2
  exit 2
fi
N=$1
DEGREE=$2
SECONDS_WINDOW=$3
BYTES=${4:-200}
DOMAIN=${RAW_CYCLONE_DOMAIN:-222}
WARMUP=${RAW_CYCLONE_WARMUP:-$((10 + N / 20))}
SEED=${RAW_CYCLONE_SEED:-1}
LINGER=1
here=$(cd "$(dirname "$0")" && pwd)
BIN=${RAW_PEER:-$here/../../build/bench/raw_cyclone/raw_peer}
[[ -x $BIN ]] || { echo "raw_cyclone.sh: no raw_peer binary at $BIN (cmake --build build --target raw_peer)" >&2; exit 2; }

workdir=$(mktemp -d /tmp/raw_cyclone.XXXXXX)
pids=()
sleeper=
cleanup() {
  set +e  # every step below must run
  local pid
  if [[ -n $sleeper ]]; then kill "$sleeper" 2>/dev/null; fi
  for pid in "${pids[@]}"; do kill -TERM "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null || true; done
  if [[ ${RAW_CYCLONE_KEEP:-0} == 1 ]]; then echo "work directory kept: $workdir" >&2; else rm -rf "$workdir"; fi
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# Graph, ports and one Cyclone XML per peer. Peer i: ParticipantIndex i % 100, Ports/Base
# 7400 + 200 (i / 100); discovery port = Base + 250 DOMAIN + 10 + 2 index = 7410 + 250 DOMAIN + 2 i, data +1.
python3 - "$N" "$DEGREE" "$SEED" "$DOMAIN" "$workdir" <<'EOF'
import math, random, socket, sys
n, degree, seed, domain, workdir = int(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), sys.argv[5]

def discovery_port(i):
    return 7400 + 200 * (i // 100) + 250 * domain + 10 + 2 * (i % 100)

low, high = discovery_port(0), discovery_port(n - 1) + 1
eph_low, eph_high = map(int, open("/proc/sys/net/ipv4/ip_local_port_range").read().split())
if high > 65535:
    sys.exit(f"domain {domain}: highest port {high} > 65535")
if not (high < eph_low or low > eph_high):
    sys.exit(f"domain {domain}: ports {low}-{high} overlap the ephemeral range {eph_low}-{eph_high}")
for i in range(n):
    for port in (discovery_port(i), discovery_port(i) + 1):
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            s.bind(("", port))
        except OSError as e:
            sys.exit(f"UDP port {port} (peer {i}) is busy: {e}")
        finally:
            s.close()

rng = random.Random(seed)
pos = [(rng.random(), rng.random()) for _ in range(n)]
pairs = sorted((math.dist(pos[i], pos[j]), i, j) for i in range(n) for j in range(i + 1, n))
edges = min(len(pairs), round(n * degree / 2))
nbrs = [[] for _ in range(n)]
for _, i, j in pairs[:edges]:
    nbrs[i].append(j)
    nbrs[j].append(i)
radius = pairs[edges - 1][0] if edges > 0 else 0.0

with open(f"{workdir}/neighbours", "w") as f:
    for i in range(n):
        f.write(f"{i} {','.join(map(str, sorted(nbrs[i]))) or '-'}\n")
for i in range(n):
    peers = "".join(f'<Peer address="127.0.0.1:{discovery_port(j)}"/>' for j in sorted(nbrs[i]))
    xml = ('<CycloneDDS><Domain id="any">'
           '<General><Interfaces><NetworkInterface name="lo"/></Interfaces><AllowMulticast>false</AllowMulticast></General>'
           f'<Discovery><ParticipantIndex>{i % 100}</ParticipantIndex><Ports><Base>{7400 + 200 * (i // 100)}</Base></Ports>'
           f'<Peers>{peers}</Peers></Discovery>'
           '<Internal><MultipleReceiveThreads>false</MultipleReceiveThreads><HeartbeatInterval>300ms</HeartbeatInterval></Internal>'
           '<Tracing><Verbosity>warning</Verbosity><OutputFile>stderr</OutputFile></Tracing>'
           '</Domain></CycloneDDS>')
    with open(f"{workdir}/peer{i}.xml", "w") as f:
        f.write(xml)
degs = [len(x) for x in nbrs]
print(f"graph: N={n} edges={edges} mean_degree={2 * edges / n:.2f} min={min(degs)} max={max(degs)} "
      f"isolated={degs.count(0)} radius={radius:.4f} (unit square, seed {seed}); ports {low}-{high} (domain {domain})")
EOF

# Wait (up to RAW_CYCLONE_IDLE_WAIT seconds, default 600) until the machine is idle: under 0.1 core busy
# over 2 s. The machine is shared (builds, other experiments); a busy machine skews every figure.
cpu_ticks() { awk '/^cpu /{t=0; for(k=2;k<=9;k++) t+=$k; print t, $5+$6, $7+$8; exit}' /proc/stat; }
idle_deadline=$(( $(date +%s) + ${RAW_CYCLONE_IDLE_WAIT:-600} ))
while :; do
  read -r t0 i0 _ < <(cpu_ticks); sleep 2; read -r t1 i1 _ < <(cpu_ticks)
  busy=$(awk -v dt=$((t1 - t0)) -v di=$((i1 - i0)) -v c="$(nproc)" 'BEGIN { printf "%.2f", (dt > 0 ? (1 - di / dt) * c : 0) }')
  if awk -v b="$busy" 'BEGIN { exit !(b < 0.1) }'; then echo "machine idle before launch (${busy} cores busy)" >&2; break; fi
  if (( $(date +%s) >= idle_deadline )); then echo "WARNING: machine still busy (${busy} cores) - measuring anyway" >&2; break; fi
  echo "machine busy (${busy} cores), waiting" >&2; sleep 8
done

start=$(python3 -c "import time; print(f'{time.time() + $WARMUP:.3f}')")
cap=$((WARMUP + SECONDS_WINDOW + LINGER + 30))
while read -r id list; do
  CYCLONEDDS_URI="file://$workdir/peer$id.xml" timeout -k 5 "$cap" "$BIN" "$id" "$DOMAIN" "$list" "$start" \
    "$SECONDS_WINDOW" "$BYTES" "$LINGER" >"$workdir/out$id" 2>"$workdir/err$id" &
  pids+=($!)
done <"$workdir/neighbours"
launched=$(python3 -c "import time; print(f'{$start - time.time():.1f}')")
echo "launched $N peers; window starts in ${launched} s (warm-up ${WARMUP} s), lasts ${SECONDS_WINDOW} s" >&2

# A background sleep and `wait`: a TERM or INT to this script runs the cleanup at once.
sleep_until() {
  sleep "$(python3 -c "import time; print(f'{max(0.0, $1 - time.time()):.3f}')")" &
  sleeper=$!
  wait "$sleeper"
  sleeper=
}
# Machine idle fraction over the window, from /proc/stat (idle + iowait over all ticks).
sleep_until "$start"
read -r total0 idle0 irq0 < <(cpu_ticks)
sleep_until "$(python3 -c "print($start + $SECONDS_WINDOW)")"
read -r total1 idle1 irq1 < <(cpu_ticks)

failed=0
for pid in "${pids[@]}"; do wait "$pid" || failed=$((failed + 1)); done
pids=()

cat "$workdir"/out* >"$workdir/all"
[[ -s "$workdir/all" ]] || { echo "no peer printed a result" >&2; head -5 "$workdir"/err* >&2 || true; exit 1; }
grep -h . "$workdir"/err* 2>/dev/null | sort | uniq -c | sort -rn | head -5 | sed 's/^/peer stderr: /' >&2 || true

awk -v n="$N" -v secs="$SECONDS_WINDOW" -v bytes="$BYTES" -v failed="$failed" \
    -v dt="$((total1 - total0))" -v di="$((idle1 - idle0))" -v dq="$((irq1 - irq0))" -v ncpu="$(nproc)" '
  { for (k = 2; k <= NF; k++) { split($k, kv, "="); v[kv[1]] = kv[2] }
    peers++; w += v["written"]; r += v["received"]; cpu += v["cpu_s"]; deg += v["neighbours"]
    mw += v["matched_writers"]; expw += v["neighbours"]
    if (v["matched_writers"] == v["neighbours"] && v["matched_readers"] == v["neighbours"]) complete++
    sent += v["written"] * v["matched_readers"]
    ws = v["window_s"] + 0; if (peers == 1 || ws < wmin) wmin = ws; if (ws > wmax) wmax = ws }
  END {
    idle = dt > 0 ? di / dt : 0
    cores = cpu / secs; rate = r / secs; busy = (1 - idle) * ncpu
    printf "peers reporting %d/%d (%d failed); discovery complete at window start: %d/%d peers, %d/%d writers matched\n", peers, n, failed, complete, peers, mw, expw
    printf "written %.0f/s (expected %.0f/s); delivered %.0f/s of %.0f/s sent to matched readers (%.1f%%); expected N*deg*10 = %.0f/s\n", w / secs, n * 10, rate, sent / secs, (sent > 0 ? 100 * r / sent : 0), deg * 10
    printf "peer CPU %.3f cores (%.1f us per delivered sample); machine busy %.3f of %d cores (non-peer %.3f, of which irq+softirq %.3f), idle fraction %.3f (%.1f us per delivered sample all included); peer windows %.3f-%.3f s\n", cores, (rate > 0 ? 1e6 * cores / rate : 0), busy, ncpu, busy - cores, (dt > 0 ? dq / dt * ncpu : 0), idle, (rate > 0 ? 1e6 * busy / rate : 0), wmin, wmax
    printf "| %d | %.2f | %d | %.0f | %.0f | %.3f | %.1f | %.3f | %.1f |\n", n, deg / peers, bytes, rate, deg * 10, cores, (rate > 0 ? 1e6 * cores / rate : 0), idle, (rate > 0 ? 1e6 * busy / rate : 0)
  }' "$workdir/all"
