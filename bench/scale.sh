#!/usr/bin/env bash
# Scale benchmark (issue 7, points 1 and 3): `swarmloc run` of scenarios/default.yaml with N agent
# processes at equal mean degree, plus a ddsperf ping/pong loopback latency reference.
#
# Usage: bench/scale.sh [N ...]            (default: 20 50 100 200)
# Environment:
#   SWARMLOC_BIN  binary to run            (default build/orchestrator/swarmloc)
#   OUT           output directory         (default runs/scale-<UTC stamp>)
#   STEPS         world steps per run      (default 150)      RATE  world rate, Hz (default 10)
#   DOMAIN_BASE   first DDS domain id      (default 215; run k uses DOMAIN_BASE + k, must stay <= 228;
#                 ddsperf uses 229). Why 215: with neighbour_discovery agent i's discovery port is
#                 7410 + 250 d + 2 i, and for d <= 214 those fixed ports fall inside Linux's ephemeral
#                 range (ip_local_port_range 32768-60999): at d = 202/203 the ephemeral sockets of the
#                 other participants took an agent's port ("rtps_init: failed to create unicast sockets",
#                 dds_create_domain Error) in 1 of 100 and 3 of 200 agents. d >= 215 puts them at >= 61160.
#   TARGET_DEGREE if set, world.area_m is tuned per N (bisection with 1-step `swarmloc sim` runs, same
#                 seed) so the mean degree is closest to this value, instead of 40 m * sqrt(N/30)
#   RUN_TIMEOUT   timeout per run, s       (default 240)
#   STARTUP_TIMEOUT  run.startup_timeout_s (default 120)
#   DDSPERF       0 = skip the ddsperf reference (default 1)
#   ALGORITHM     algorithm.name of every run (default: the scenario's, dml)
#   AGENT_NICE    run.agent_nice (default 0): agents this much nicer than the orchestrator, which then
#                 keeps the world's rate when the agents saturate the machine (N = 500 on 2 cores)
#
# Per N: area = 40 m * sqrt(N/30) (comm radius kept at 15 m), anchors = round(8 N / 30), so the mean
# degree stays about equal (the summary's mean_degree is reported to check that). Measured:
#   discovery      from the agents' own logs (logs/agent_XXX.log): for agent i, t_full(i) = first
#                  "matched k/k neighbours" line (its reader has matched every neighbour's writer).
#                  disc_all_s   = max_i t_full(i) - min_i t_started(i)  (first agent process up -> last
#                                 agent with all neighbours); the acceptance figure.
#                  launch_s     = max_i t_started(i) - min_i t_started(i) (the orchestrator starts the
#                                 agent processes one after another).
#                  disc_med_s / disc_max_s = median / max of t_full(i) - t_started(i) (per agent).
#                  start_s      = the orchestrator's "all N agents reporting after X s; START" figure.
#   CPU/agent      summary.json cpu_per_agent_fraction: mean over agents of the CPU the agent process
#                  used from START to STOP, divided by the wall time from START to STOP (world_phase_s). Start-up and
#                  discovery are excluded (the agents log them separately; pre_start_cpu_s column).
#                  Only agents that received START report it: check "agents that got START".
#   RSS/agent      VmRSS of every agent process sampled every 0.5 s from /proc; per process the max,
#                  reported as the median (and max) over processes.
#   rx/s/agent     sum of links.csv delivered / N / (steps / rate).
#   delivered      delivered / expected, expected = sum over directed links (i -> j) of the samples
#                  agent i published (agents.csv samples_published): every sample an agent wrote should
#                  reach each neighbour. Samples written before a neighbour had matched count as missing.
#                  Also delivered / (links * steps) (one sample per neighbour per world step) and the
#                  in-transport ratio delivered / sent (sent inferred by the receiver from the seq range).
#                  "in steps": the same counting only samples written in a step (header step >= 0) on both
#                  sides (links.csv delivered_in_steps, agents.csv samples_published_in_steps), i.e. without
#                  the start-up announcements, which go out while neighbours are still being discovered.
#   world rate     summary.json health.figures.world_rate_hz (steps run / START to the last step; older
#                  binaries: steps / world_steps_s): below the scenario's rate when the orchestrator cannot
#                  keep up. CPU/agent is normalized by world_phase_s (START to STOP, the span the agents
#                  report CPU over).
#   health         summary.json health: verdict, late world steps (% of steps published more than half a
#                  period late), late ticks (% of agent ticks late), stalls; the reasons of a run that is
#                  not healthy are listed below the table ("N=400: ...").
#   orchestrator   summary.json orchestrator (absent in older binaries: "–"): priority (realtime/normal),
#                  world-thread CPU ms per step (step.cpu_ms_mean) and the whole process's CPU ms per step;
#                  scale.csv also has the longest step (wall) and each phase's CPU ms per step.
#   RMSE           summary.json final.rmse_m.
#   other_cpu      machine CPU used by processes other than this run during the run (from /proc/stat
#                  minus this run's processes), in cores: the machine is shared.
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)
bin=${SWARMLOC_BIN:-build/orchestrator/swarmloc}
bin=$(readlink -f "$bin")
steps=${STEPS:-150}
rate=${RATE:-10}
domain_base=${DOMAIN_BASE:-215}
run_timeout=${RUN_TIMEOUT:-240}
startup_timeout=${STARTUP_TIMEOUT:-120}
agent_nice=${AGENT_NICE:-0}
algorithm_set=()
[ -z "${ALGORITHM:-}" ] || algorithm_set=(--set "algorithm.name=$ALGORITHM")
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(20 50 100 200)
out=${OUT:-runs/scale-$(date -u +%Y%m%d-%H%M%S)}
mkdir -p "$out"
out=$(readlink -f "$out")
echo "scale benchmark: ${sizes[*]} agents, $steps steps at $rate Hz; output $out" >&2

# --- machine ------------------------------------------------------------------------------------
{
  echo "date_utc: $(date -u +%FT%TZ)"
  echo "nproc: $(nproc)"
  echo "mem: $(awk '/MemTotal/ {printf "%.1f GiB", $2/1048576}' /proc/meminfo)"
  echo "kernel: $(uname -r)"
  echo "cpu: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//')"
  echo "binary: $bin"
  echo "commit: $(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
  echo "command: bench/scale.sh ${sizes[*]}"
  echo "agent_nice: $agent_nice"
  # The machine is shared: what else was running when this started (other_cores covers the runs).
  echo "loadavg: $(cut -d' ' -f1-3 /proc/loadavg)"
  echo "busiest other processes (%cpu command):"
  ps -eo pcpu=,comm= --sort=-pcpu | head -5 | sed 's/^/  /'
} > "$out/machine.txt"

# --- ddsperf loopback reference (ping/pong, see docs/measurements/ddsperf.md) ----------------------------
ddsperf_ref() {  # tag seconds mode-args... ; writes $out/ddsperf-<tag>.txt
  local tag=$1 seconds=$2; shift 2
  local dom=229
  CYCLONEDDS_URI='<General><Interfaces><NetworkInterface name="lo" multicast="true"/></Interfaces></General>' \
    timeout $((seconds + 18)) ddsperf -i "$dom" -D $((seconds + 2)) pong > "$out/ddsperf-$tag-pong.txt" 2>&1 &
  local pong=$!
  sleep 0.5
  CYCLONEDDS_URI='<General><Interfaces><NetworkInterface name="lo" multicast="true"/></Interfaces></General>' \
    timeout $((seconds + 18)) ddsperf -i "$dom" -D "$seconds" ping "$@" > "$out/ddsperf-$tag.txt" 2>&1 || true
  kill "$pong" 2>/dev/null || true
  wait "$pong" 2>/dev/null || true
}
if [ "${DDSPERF:-1}" != 0 ]; then
  if ! command -v ddsperf >/dev/null; then
    echo "ddsperf not found (apt-get install cyclonedds-tools); skipping the latency reference" >&2
  else
    # The agents publish at the world rate, so their wake-ups come after ~1/rate of idle; ddsperf at the
    # same rate is the like-for-like reference (on this VM waking from 100 ms idle costs ~4x more than
    # from 10 ms: one way p50 ~300 us at 10 Hz against ~60 us at 100 Hz, docs/measurements/ddsperf.md).
    echo "ddsperf reference: back-to-back, 100 Hz (12 s each) and ${rate} Hz (32 s) ping size 64" >&2
    ddsperf_ref b2b 12 size 64
    ddsperf_ref 100hz 12 100Hz size 64
    ddsperf_ref rate 32 "${rate}Hz" size 64
  fi
fi

# --- one swarmloc run per N -----------------------------------------------------------------------
sample_rss() {  # run_dir pid_of_orchestrator -> $run_dir/rss.csv, $run_dir/cpu.csv until the orchestrator exits
  local dir=$1 opid=$2
  python3 - "$dir" "$opid" "$bin" <<'PY'
import os, sys, time
d, opid, binpath = sys.argv[1], int(sys.argv[2]), sys.argv[3]
hz = os.sysconf("SC_CLK_TCK")
def cpu_total():
    f = open("/proc/stat").readline().split()[1:]
    v = list(map(int, f)); idle = v[3] + v[4]
    return sum(v[:8]) - idle
def ours():  # pid -> (cmdline, rss_kib, cpu ticks) for processes of this binary
    r = {}
    for p in os.listdir("/proc"):
        if not p.isdigit(): continue
        try:
            exe = os.readlink(f"/proc/{p}/exe")
            if exe not in (binpath, os.path.join(os.path.dirname(binpath), "swarmloc-agent")): continue  # agents: the lean binary
            cmd = open(f"/proc/{p}/cmdline", "rb").read().replace(b"\0", b" ").decode()
            ppid = int(open(f"/proc/{p}/stat").read().split(") ")[1].split()[1])
            if int(p) != opid and ppid != opid: continue  # the orchestrator and the agents it launched
            rss = 0
            for line in open(f"/proc/{p}/status"):
                if line.startswith("VmRSS:"): rss = int(line.split()[1])
            st = open(f"/proc/{p}/stat").read().split(") ")[1].split()
            r[int(p)] = (cmd, rss, int(st[11]) + int(st[12]))
        except (OSError, IndexError, ValueError):
            pass
    return r
rss_max, ticks_last = {}, {}
t0 = time.time(); m0 = cpu_total()
samples = []
while os.path.exists(f"/proc/{opid}"):
    now = time.time(); m = cpu_total(); o = ours()
    for p, (cmd, rss, t) in o.items():
        if " agent " in cmd or " --manifest " in cmd:
            rss_max[p] = max(rss_max.get(p, 0), rss)
        ticks_last[p] = t
    samples.append((now - t0, m - m0, sum(ticks_last.values()), len(o)))
    time.sleep(0.5)
with open(f"{d}/rss.csv", "w") as f:
    f.write("pid,max_vmrss_kib\n")
    for p, v in sorted(rss_max.items()): f.write(f"{p},{v}\n")
with open(f"{d}/cpu.csv", "w") as f:  # cumulative: machine busy ticks, ticks of this run's processes
    f.write("t_s,machine_busy_ticks,run_ticks,processes\n")
    for s in samples: f.write(f"{s[0]:.2f},{s[1]},{s[2]},{s[3]}\n")
PY
}

tune_area() {  # N anchors area0 -> area giving a mean degree closest to TARGET_DEGREE (1-step in-process sims)
  python3 - "$1" "$2" "$3" "$TARGET_DEGREE" "$bin" <<'PY'
import json, subprocess, sys, tempfile
n, anchors, a0, target, binary = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), sys.argv[5]
lo, hi = 0.6 * a0, 1.6 * a0
for _ in range(12):
    a = (lo + hi) / 2
    d = tempfile.mkdtemp(prefix="scale-tune-")
    ok = subprocess.run([binary, "sim", "scenarios/default.yaml", "-q", "--out", d, "--set", f"world.agents={n}",
                         "--set", f"world.anchors={anchors}", "--set", f"world.area_m={a}", "--set", "run.steps=1"],
                        capture_output=True).returncode == 0
    degree = json.load(open(d + "/summary.json"))["mean_degree"] if ok else 0.0
    subprocess.run(["rm", "-rf", d])
    lo, hi = (lo, a) if degree < target else (a, hi)   # a bigger area lowers the degree
print(round((lo + hi) / 2, 2))
PY
}

k=0
: > "$out/runs.txt"
for n in "${sizes[@]}"; do
  dom=$((domain_base + k)); k=$((k + 1))
  if [ "$dom" -gt 228 ]; then echo "domain $dom > 228: too many sizes for DOMAIN_BASE=$domain_base" >&2; exit 2; fi
  lo_port=$(awk '{print $2}' /proc/sys/net/ipv4/ip_local_port_range)
  [ $((7410 + 250 * dom)) -gt "$lo_port" ] || echo "warning: domain $dom's agent ports start at $((7410 + 250 * dom)), inside the ephemeral port range (up to $lo_port)" >&2
  area=$(python3 -c "import math; print(round(40*math.sqrt($n/30), 2))")
  anchors=$(python3 -c "print(max(1, round(8*$n/30)))")
  [ -z "${TARGET_DEGREE:-}" ] || area=$(tune_area "$n" "$anchors" "$area")
  dir="$out/n$n"
  rm -rf "$dir"
  echo "N=$n: area $area m, $anchors anchors, domain $dom" >&2
  start=$(date +%s.%N)
  set +e
  timeout --signal=INT --kill-after=20 "$run_timeout" "$bin" run scenarios/default.yaml -q --out "$dir" \
    --set world.agents="$n" --set world.anchors="$anchors" --set world.area_m="$area" \
    --set run.steps="$steps" --set run.rate_hz="$rate" --set dds.domain_id="$dom" \
    --set run.startup_timeout_s="$startup_timeout" --set run.agent_nice="$agent_nice" "${algorithm_set[@]}" \
    > "$out/n$n.out" 2>&1 &
  rpid=$!
  sleep 0.3
  opid=$(pgrep -P "$rpid" -f "$bin" | head -1 || true)
  [ -n "$opid" ] && mkdir -p "$dir" && sample_rss "$dir" "$opid" &
  spid=$!
  wait "$rpid"; rc=$?
  wait "$spid" 2>/dev/null
  set -e
  end=$(date +%s.%N)
  echo "n=$n domain=$dom area=$area anchors=$anchors rc=$rc elapsed=$(python3 -c "print(round($end-$start,1))")" >> "$out/runs.txt"
  echo "  rc=$rc" >&2
  sleep 3  # let the loopback sockets settle before the next size
done

# --- tables, plot ---------------------------------------------------------------------------------
python3 - "$out" "$steps" "$rate" <<'PY'
import csv, glob, json, os, re, statistics, sys
from datetime import datetime
out, steps, rate = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
runs = [dict(kv.split("=") for kv in l.split()) for l in open(f"{out}/runs.txt") if l.strip()]
ts = lambda s: datetime.fromisoformat(s).timestamp()

def ddsperf(tag):  # printed values are RTT/2 (ddsperf.c 0.10.2); report RTT, medians of the 1-s lines after t=2.5 s
    p = f"{out}/ddsperf-{tag}.txt"
    if not os.path.exists(p): return None
    p50, p99 = [], []
    for l in open(p):
        m = re.search(r"\] (\d+\.\d+)\s+\S+ size \d+ .* 50% ([\d.]+)us .* 99% ([\d.]+)us", l)
        if m and float(m.group(1)) > 2.5: p50.append(2 * float(m.group(2))); p99.append(2 * float(m.group(3)))
    if not p50: return None
    return {"rtt_p50_us": statistics.median(p50), "rtt_p99_us": statistics.median(p99), "rtt_p99_max_us": max(p99), "seconds": len(p50)}
ref = {t: ddsperf(t) for t in ("b2b", "100hz", "rate")}
json.dump(ref, open(f"{out}/ddsperf.json", "w"), indent=1)

rows = []
for r in runs:
    n = int(r["n"]); d = f"{out}/n{n}"
    row = {"n": n, "rc": int(r["rc"]), "domain": int(r["domain"]), "area_m": float(r["area"]), "anchors": int(r["anchors"]),
           "elapsed_s": float(r["elapsed"])}
    o = open(f"{out}/n{n}.out").read() if os.path.exists(f"{out}/n{n}.out") else ""
    m = re.search(r"all \d+ agents reporting after ([\d.]+) s", o)
    row["start_s"] = float(m.group(1)) if m else None
    # discovery from the agent logs
    started, full, final_match, nb = {}, {}, {}, {}
    for f in sorted(glob.glob(f"{d}/logs/agent_*.log")):
        a = int(re.search(r"agent_(\d+)\.log$", f).group(1))
        for l in open(f, errors="replace"):
            m = re.match(r"(\S+) \w+ \[agent\d+\] started: (\d+) neighbours", l)
            if m: started[a] = ts(m.group(1)); nb[a] = int(m.group(2))
            m = re.match(r"(\S+) \w+ \[agent\d+\] matched (\d+)/(\d+) neighbours", l)
            if m:
                final_match[a] = (int(m.group(2)), int(m.group(3)))
                if m.group(2) == m.group(3) and a not in full: full[a] = ts(m.group(1))
        if a in nb and nb[a] == 0 and a in started and a not in full: full[a] = started[a]
    row["agents_logged"] = len(started)
    row["agents_all_matched"] = len(full)
    row["agents_matched_at_end"] = sum(1 for v in final_match.values() if v[0] == v[1])
    if started and len(full) == len(started) == n:
        t0 = min(started.values())
        row["disc_all_s"] = max(full.values()) - t0
        per = [full[a] - started[a] for a in full]
        row["disc_med_s"] = statistics.median(per); row["disc_max_s"] = max(per)
        row["launch_s"] = max(started.values()) - t0
    else:
        row["disc_all_s"] = row["disc_med_s"] = row["disc_max_s"] = row["launch_s"] = None
    sp = f"{d}/summary.json"
    if os.path.exists(sp):
        s = json.load(open(sp))
        row["mean_degree"] = s.get("mean_degree")
        row["cpu_frac"] = s.get("cpu_per_agent_fraction"); row["cpu_s"] = s.get("cpu_per_agent_s")
        row["rmse_m"] = (s.get("final") or {}).get("rmse_m"); row["interrupted"] = s.get("interrupted")
        links = list(csv.DictReader(open(f"{d}/links.csv")))
        row["agents_started"] = sum(1 for a in csv.DictReader(open(f"{d}/agents.csv")) if int(a["steps_run"]) > 0)
        agents = {int(a["agent"]): a for a in csv.DictReader(open(f"{d}/agents.csv"))}
        # directed neighbour links: from the agents' "started: k neighbours" lines (links.csv only lists links that carried data)
        nlinks = sum(nb.values())
        delivered = sum(int(l["delivered"]) for l in links)
        sent = sum(int(l["sent"]) for l in links)
        expected = sum(nb[a] * int(agents[a]["samples_published"]) for a in nb if a in agents)
        # The same, counting only samples written in a step (step >= 0), not the start-up announcements
        delivered_steps = sum(int(l.get("delivered_in_steps") or 0) for l in links)
        expected_steps = sum(nb[a] * int(agents[a].get("samples_published_in_steps") or 0) for a in nb if a in agents)
        row["delivered_steps"] = delivered_steps; row["expected_steps"] = expected_steps
        row["ratio_expected_steps"] = delivered_steps / expected_steps if expected_steps else None
        row["world_phase_s"] = s.get("world_phase_s")
        ws = s.get("world_steps_s")
        health = s.get("health") or {}; hf = health.get("figures") or {}
        # the health figure counts the steps actually run (an interrupted run ran fewer than STEPS)
        row["world_hz"] = hf.get("world_rate_hz", steps / ws if ws else None)
        row["verdict"] = health.get("verdict"); row["reasons"] = health.get("reasons") or []
        row["health_reasons"] = "; ".join(row["reasons"])
        row["late_world_steps"] = hf.get("late_world_steps"); row["world_steps"] = hf.get("world_steps")
        row["late_world_step_frac"] = (hf["late_world_steps"] / hf["world_steps"]
                                       if hf.get("world_steps") and hf.get("late_world_steps") is not None else None)
        row["late_tick_frac"] = hf.get("late_tick_fraction"); row["stalls"] = hf.get("stalls")
        orch = s.get("orchestrator") or {}  # absent in older binaries
        row["orch_priority"] = orch.get("priority")
        row["orch_process_cpu_ms"] = orch.get("process_cpu_ms_per_step")
        row["orch_step_cpu_ms"] = (orch.get("step") or {}).get("cpu_ms_mean")
        row["orch_step_wall_ms_max"] = (orch.get("step") or {}).get("wall_ms_max")
        for ph in ("generate", "publish", "take", "score"):
            row[f"orch_{ph}_cpu_ms"] = (orch.get(ph) or {}).get("cpu_ms_mean")
        dur = steps / rate
        row["links"] = nlinks; row["links_with_data"] = len(links)
        row["delivered"] = delivered; row["expected"] = expected
        row["ratio_expected"] = delivered / expected if expected else None
        row["ratio_steps"] = delivered / (nlinks * steps) if nlinks else None
        row["ratio_sent"] = delivered / sent if sent else None
        row["rx_per_agent_s"] = delivered / n / dur
        pre = []
        for f in glob.glob(f"{d}/logs/agent_*.log"):
            for l in open(f, errors="replace"):
                m = re.search(r"CPU before START \(start-up and discovery\): ([\d.]+) s", l)
                if m: pre.append(float(m.group(1)))
        row["pre_start_cpu_s"] = statistics.median(pre) if pre else None
        # inter-agent latency: each agent logs p50/p99 of its own samples; report the median agent's p50
        # and the median and worst of the agents' p99
        lat50, lat99 = [], []
        for f in glob.glob(f"{d}/logs/agent_*.log"):
            for l in open(f, errors="replace"):
                m = re.search(r"inter-agent latency \(source timestamp to take\): p50 ([\d.]+) us p99 ([\d.]+) us", l)
                if m: lat50.append(float(m.group(1))); lat99.append(float(m.group(2)))
        row["lat_p50_us"] = statistics.median(lat50) if lat50 else None
        row["lat_p99_us"] = statistics.median(lat99) if lat99 else None
        row["lat_p99_max_us"] = max(lat99) if lat99 else None
    rp = f"{d}/rss.csv"
    if os.path.exists(rp):
        v = [int(x["max_vmrss_kib"]) / 1024 for x in csv.DictReader(open(rp))]
        row["rss_med_mib"] = statistics.median(v) if v else None; row["rss_max_mib"] = max(v) if v else None
        row["rss_procs"] = len(v)
    cp = f"{d}/cpu.csv"
    if os.path.exists(cp):
        c = list(csv.DictReader(open(cp)))
        if len(c) > 4:
            a, b = c[1], c[-1]; dt = float(b["t_s"]) - float(a["t_s"]); hz = os.sysconf("SC_CLK_TCK")
            busy = (int(b["machine_busy_ticks"]) - int(a["machine_busy_ticks"])) / hz / dt
            mine = (int(b["run_ticks"]) - int(a["run_ticks"])) / hz / dt
            row["machine_busy_cores"] = busy; row["run_cores"] = mine; row["other_cores"] = max(0.0, busy - mine)
    rows.append(row)

keys = ["n", "rc", "domain", "area_m", "anchors", "mean_degree", "agents_started", "launch_s", "disc_all_s", "disc_med_s", "disc_max_s",
        "start_s", "agents_all_matched", "agents_matched_at_end", "cpu_frac", "cpu_s", "pre_start_cpu_s", "rss_med_mib",
        "rss_max_mib", "rss_procs", "rx_per_agent_s", "links", "links_with_data", "delivered", "expected",
        "ratio_expected", "delivered_steps", "expected_steps", "ratio_expected_steps", "ratio_steps", "ratio_sent",
        "world_phase_s", "world_hz", "lat_p50_us", "lat_p99_us", "lat_p99_max_us", "rmse_m", "run_cores", "other_cores", "machine_busy_cores",
        "elapsed_s", "verdict", "late_world_steps", "world_steps", "late_world_step_frac", "late_tick_frac", "stalls",
        "orch_priority", "orch_step_cpu_ms", "orch_process_cpu_ms", "orch_step_wall_ms_max", "orch_generate_cpu_ms",
        "orch_publish_cpu_ms", "orch_take_cpu_ms", "orch_score_cpu_ms", "health_reasons"]
with open(f"{out}/scale.csv", "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=keys, extrasaction="ignore"); w.writeheader()
    for r in rows: w.writerow({k: ("" if r.get(k) is None else (round(r[k], 6) if isinstance(r[k], float) else r[k])) for k in keys})

def fmt(v, spec, scale=1.0):
    return "–" if v is None else format(v * scale, spec)
lines = ["| N | mean degree | agents that got START | launch spread (s) | discovery all (s) | per-agent disc. med / max (s) | START after (s) | CPU/agent (% core) | RSS/agent med / max (MiB) | samples rx/s/agent | delivered / expected | delivered / expected, in steps | delivered / sent (seq) | world rate (Hz) | final RMSE (m) | other load (cores) | rc | verdict | late world steps (%) | late ticks (%) | stalls | orch. priority | orch. world thread CPU/step (ms) | orch. process CPU/step (ms) |",
         "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
for r in rows:
    lines.append(f"| {r['n']} | {fmt(r.get('mean_degree'), '.2f')} | {r.get('agents_started', '–')}/{r['n']} | {fmt(r.get('launch_s'), '.1f')} | {fmt(r.get('disc_all_s'), '.2f')} | "
                 f"{fmt(r.get('disc_med_s'), '.2f')} / {fmt(r.get('disc_max_s'), '.2f')} | {fmt(r.get('start_s'), '.1f')} | "
                 f"{fmt(r.get('cpu_frac'), '.2f', 100)} | {fmt(r.get('rss_med_mib'), '.1f')} / {fmt(r.get('rss_max_mib'), '.1f')} | "
                 f"{fmt(r.get('rx_per_agent_s'), '.1f')} | {fmt(r.get('ratio_expected'), '.2f', 100)} % | "
                 f"{fmt(r.get('ratio_expected_steps'), '.2f', 100)} % | "
                 f"{fmt(r.get('ratio_sent'), '.2f', 100)} % | {fmt(r.get('world_hz'), '.2f')} | "
                 f"{fmt(r.get('rmse_m'), '.4f')} | {fmt(r.get('other_cores'), '.2f')} | {r['rc']} | "
                 f"{r.get('verdict') or '–'} | {fmt(r.get('late_world_step_frac'), '.1f', 100)} | {fmt(r.get('late_tick_frac'), '.1f', 100)} | "
                 f"{fmt(r.get('stalls'), '.0f')} | {r.get('orch_priority') or '–'} | {fmt(r.get('orch_step_cpu_ms'), '.2f')} | "
                 f"{fmt(r.get('orch_process_cpu_ms'), '.2f')} |")
lines.append("")
# why a run is not healthy (summary.json health.reasons)
reasons = [f"- N={r['n']}: {x}" for r in rows for x in r.get("reasons", [])]
lines += reasons + [""] if reasons else []
for t, name in (("b2b", "back-to-back, 64 B"), ("100hz", "100 Hz, 64 B"), ("rate", f"{rate:g} Hz = the agents' rate, 64 B")):
    v = ref.get(t)
    lines.append(f"ddsperf ping/pong ({name}): " + ("not run" if not v else
                 f"RTT p50 {v['rtt_p50_us']:.0f} µs, p99 {v['rtt_p99_us']:.0f} µs (median of {v['seconds']} 1-s windows; worst 1-s p99 {v['rtt_p99_max_us']:.0f} µs)"))
for r in rows:
    if r.get("lat_p50_us") is None: continue
    lines.append(f"agent-to-agent latency at N={r['n']} (one way, writer's source timestamp to the reader's take): "
                 f"p50 {r['lat_p50_us']:.0f} µs (median agent), p99 {r['lat_p99_us']:.0f} µs (median agent; worst {r['lat_p99_max_us']:.0f} µs)")
    for t, name in (("rate", f"{rate:g} Hz (the agents' rate)"), ("100hz", "100 Hz")):
        v = ref.get(t)
        if v: lines.append(f"  vs ddsperf at {name}, one way (RTT/2) p50 {v['rtt_p50_us'] / 2:.0f} µs: {r['lat_p50_us'] / (v['rtt_p50_us'] / 2):.2f}x")
open(f"{out}/scale.md", "w").write("\n".join(lines) + "\n")
print("\n".join(lines))

# plot: CPU per agent and delivered ratio vs N
ok = [r for r in rows if r.get("cpu_frac") is not None]
with open(f"{out}/scale.dat", "w") as f:
    for r in ok: f.write(f"{r['n']} {100*r['cpu_frac']:.4f} {100*(r.get('ratio_expected') or 0):.4f} {100*(r.get('ratio_sent') or 0):.4f}\n")
open(f"{out}/scale.gp", "w").write(f"""set terminal pngcairo size 900,500 font ",11" noenhanced
set output "{out}/scale.png"
set multiplot layout 1,2 title "swarmloc run, scenarios/default.yaml scaled to N agents, {steps} steps at {rate:g} Hz"
set xlabel "agents N"; set grid; set key bottom right
set ylabel "CPU per agent (% of one core)"; set yrange [0:*]
plot "{out}/scale.dat" u 1:2 w lp pt 7 lw 2 t "cpu_per_agent_fraction"
set ylabel "delivered (%)"; set yrange [*:100.5]
plot "{out}/scale.dat" u 1:3 w lp pt 7 lw 2 t "delivered / expected", "" u 1:4 w lp pt 5 lw 2 t "delivered / sent (seq)"
unset multiplot
""")
os.system(f"gnuplot {out}/scale.gp")
PY
echo "wrote $out/scale.md, scale.csv, scale.png" >&2
