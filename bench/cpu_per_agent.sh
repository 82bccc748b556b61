#!/usr/bin/env bash
# Per-agent CPU as N grows at equal mean degree (issue 2 point 9, docs/design.md §4).
# The area grows with sqrt(N), anchors stay at 8/30 of the agents, and the radius is tuned per N (with
# 1-step in-process runs) so that the mean degree hits TARGET_DEGREE (default 9) despite edge effects.
# Usage: bench/cpu_per_agent.sh [N ...]   (default: 20 100). Prints one table row per N.
set -euo pipefail
cd "$(dirname "$0")/.."
binary=build/orchestrator/swarmloc
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(20 100)
out=$(mktemp -d)
target_degree=${TARGET_DEGREE:-9}
tune_radius() {  # N area anchors -> radius giving mean degree closest to the target
  python3 - "$1" "$2" "$3" "$target_degree" "$binary" <<'PY'
import json, subprocess, sys, tempfile
n, area, anchors, target, binary = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4]), sys.argv[5]
lo, hi = 3.0, 60.0
for _ in range(14):
    r = (lo + hi) / 2
    d = tempfile.mkdtemp()
    ok = subprocess.run([binary, "sim", "scenarios/default.yaml", "-q", "--out", d, "--set", f"world.agents={n}",
                         "--set", f"world.anchors={anchors}", "--set", f"world.area_m={area}",
                         "--set", f"world.comm_radius_m={r}", "--set", "run.steps=1"],
                        capture_output=True).returncode == 0
    degree = json.load(open(d + "/summary.json"))["mean_degree"] if ok else 0.0
    lo, hi = (r, hi) if degree < target else (lo, r)
print(round((lo + hi) / 2, 3))
PY
}
printf '| N | area (m) | radius (m) | mean degree | final RMSE (m) | CPU per agent (%% of a core) | CPU per agent (s) | wall (s) | delivered / sent |\n'
printf '|---|---|---|---|---|---|---|---|---|\n'
for n in "${sizes[@]}"; do
  area=$(python3 -c "import math; print(round(40*math.sqrt($n/30), 2))")
  anchors=$(( (n * 8 + 29) / 30 ))
  radius=$(tune_radius "$n" "$area" "$anchors")
  "$binary" run scenarios/default.yaml -q --out "$out/n$n" --set world.agents="$n" --set world.anchors="$anchors" \
    --set world.area_m="$area" --set world.comm_radius_m="$radius" --set run.steps=300 --set run.rate_hz=10 >/dev/null
  python3 - "$out/n$n/summary.json" "$n" "$area" "$radius" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
links = s["links"]
print(f"| {sys.argv[2]} | {sys.argv[3]} | {sys.argv[4]} | {s['mean_degree']:.2f} | {s['final']['rmse_m']:.4f} | "
      f"{100*s['cpu_per_agent_fraction']:.2f} | {s['cpu_per_agent_s']:.3f} | {s['wall_s']:.1f} | "
      f"{links['delivered']}/{links['sent']} |")
PY
done
rm -rf "$out"
