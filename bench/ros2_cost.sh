#!/usr/bin/env bash
# What dds.ros2 costs (docs/ros2.md, "Cost"): the default scenario (30 agents, 300 steps at 10 Hz), runs
# alternating between configurations so that machine load hits them alike. Per run: the agents' mean CPU
# since START (summary.json cpu_per_agent_s), the total CPU of `swarmloc run` and all its processes
# (/usr/bin/time), and the inter-agent samples each agent wrote per world step (agents.csv).
# Usage: bench/ros2_cost.sh [ROUNDS]   (default 3). BASELINE=/path/to/an/older/swarmloc adds a column
# for that binary (e.g. one built from the commit before dds.ros2), run with the same flags; BINARY=… replaces
# build/orchestrator/swarmloc (a copy keeps a rebuild during the benchmark from changing it).
# ROS2_READER=build/tests/ros2_reader adds "on+reader": dds.ros2 on with that subscriber to every ROS topic
# (through deploy/ros2/cyclonedds.xml), so the ROS samples are really sent; its own CPU is not counted.
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=${1:-3}
binary=${BINARY:-build/orchestrator/swarmloc}
out=$(mktemp -d)
configs=("off:$binary:" "on:$binary:--set dds.ros2=true")
[ -n "${BASELINE:-}" ] && configs=("baseline:$BASELINE:" "${configs[@]}")
[ -n "${ROS2_READER:-}" ] && configs+=("on+reader:$binary:--set dds.ros2=true")
for round in $(seq 1 "$rounds"); do
  for config in "${configs[@]}"; do
    IFS=: read -r name bin flags <<<"$config"
    dir="$out/$name-$round"
    reader=""
    if [ "$name" = "on+reader" ]; then
      CYCLONEDDS_URI="file://$PWD/deploy/ros2/cyclonedds.xml" "$ROS2_READER" 73 30 600 >/dev/null 2>&1 &
      reader=$!
    fi
    # shellcheck disable=SC2086
    /usr/bin/time -f "%U %S" -o "$dir.time" "$bin" run scenarios/default.yaml -q --out "$dir" \
      --set dds.domain_id=73 $flags >/dev/null
    [ -z "$reader" ] || wait "$reader"  # it ends once the run's ROS writers are gone
  done
done
python3 - "$out" "$rounds" "${configs[@]}" <<'PY'
import csv, json, statistics, sys
out, rounds, configs = sys.argv[1], int(sys.argv[2]), [c.split(":")[0] for c in sys.argv[3:]]
print("| configuration | agent CPU since START, mean per agent (s) | total CPU of the run (s) | inter-agent samples per agent per world step | final RMSE (m) |")
print("|---|---|---|---|---|")
for name in configs:
    cpu, total, samples, rmse = [], [], [], []
    for r in range(1, rounds + 1):
        d = f"{out}/{name}-{r}"
        s = json.load(open(d + "/summary.json"))
        cpu.append(s["cpu_per_agent_s"])
        rmse.append(s["final"]["rmse_m"])
        user, system = map(float, open(d + ".time").read().split()[-2:])
        total.append(user + system)
        rows = list(csv.DictReader(open(d + "/agents.csv")))
        samples.append(sum(int(a["samples_published_in_steps"]) for a in rows) / len(rows) / s["steps"])
    fmt = lambda v: f"{statistics.median(v):.3f} (min {min(v):.3f}, max {max(v):.3f})"
    print(f"| {name} | {fmt(cpu)} | {fmt(total)} | {statistics.median(samples):.2f} | {statistics.median(rmse):.4f} |")
PY
rm -rf "$out"
