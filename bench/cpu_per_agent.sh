#!/usr/bin/env bash
# Per-agent CPU as N grows at equal mean degree (issue 2 point 9, DESIGN.md §4).
# The area grows with sqrt(N) and anchors stay at 8/30 of the agents, so density and degree are fixed.
# Usage: bench/cpu_per_agent.sh [N ...]   (default: 20 100). Prints one table row per N.
set -euo pipefail
cd "$(dirname "$0")/.."
binary=build/orchestrator/swarmloc
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(20 100)
out=$(mktemp -d)
printf '| N | area (m) | mean degree | final RMSE (m) | CPU per agent (%% of a core) | CPU per agent (s) | wall (s) | delivered / sent |\n'
printf '|---|---|---|---|---|---|---|---|\n'
for n in "${sizes[@]}"; do
  area=$(python3 -c "import math; print(round(40*math.sqrt($n/30), 2))")
  anchors=$(( (n * 8 + 29) / 30 ))
  "$binary" run scenarios/default.yaml -q --out "$out/n$n" --set world.agents="$n" --set world.anchors="$anchors" \
    --set world.area_m="$area" --set run.steps=300 --set run.rate_hz=10 >/dev/null
  python3 - "$out/n$n/summary.json" "$n" "$area" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
links = s["links"]
print(f"| {sys.argv[2]} | {sys.argv[3]} | {s['mean_degree']:.1f} | {s['final']['rmse_m']:.4f} | "
      f"{100*s['cpu_per_agent_fraction']:.2f} | {s['cpu_per_agent_s']:.3f} | {s['wall_s']:.1f} | "
      f"{links['delivered']}/{links['sent']} |")
PY
done
rm -rf "$out"
