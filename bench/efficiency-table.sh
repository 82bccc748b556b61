#!/usr/bin/env bash
# The efficiency tables of docs/validation.md (issue 44): an estimator's final RMSE over the optimum of each
# trial's own data (docs/algorithms.md §1.3.2), beside its RMSE over the bound, on the default scenario
# scaled to N agents at the default density (area 40·√(N/30) m, 8/30 of them anchors).
# Usage: bench/efficiency-table.sh ALGORITHM N TRIALS [extra --set…]; prints one markdown row:
# N, mean degree, trials, MC RMSE, bound, ÷ bound, optimum (√ mean of squares), pooled efficiency
# (√(Σ RMSE² / Σ optimum²)), per-trial efficiency median and range, trial 0's optimum NEES, and the CPU
# of a trial (the Monte Carlo's wall time × threads / trials) with trial 0's optimum cost (observe + solve)
# and its share.
set -euo pipefail
cd "$(dirname "$0")/.."
algorithm=$1 n=$2 trials=$3
shift 3
swarmloc=${SWARMLOC:-build/orchestrator/swarmloc}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
area=$(python3 -c "import math; print(round(40 * math.sqrt($n / 30), 2))")
anchors=$(python3 -c "print(round(8 * $n / 30))")
"$swarmloc" sim scenarios/default.yaml -q --trials "$trials" --set algorithm.name="$algorithm" \
  --set world.agents="$n" --set world.anchors="$anchors" --set world.area_m="$area" "$@" \
  --out "$work/run" >/dev/null 2>&1
python3 - "$work/run" "$n" <<'PY'
import csv, json, math, statistics, sys
run, n = sys.argv[1:]
summary = json.load(open(f"{run}/summary.json"))
mc = summary["monte_carlo"]
rows = list(csv.DictReader(open(f"{run}/trials.csv")))
eff = sorted(float(r["efficiency"]) for r in rows)
optimum = summary["optimum"]
cost = optimum["observe_cpu_s"] + optimum["solve_cpu_s"]
per_trial = summary["wall_s"] * mc["threads"] / len(rows)
print(f"| {n} | {summary['mean_degree']:.1f} | {len(rows)} | {mc['mc_rmse_m']:.5f} m | {mc['bound_rmse_m']:.5f} m | "
      f"{mc['ratio']:.3f} | {mc['optimum_rmse_m']:.5f} m | **{mc['efficiency']:.3f}** | "
      f"{statistics.median(eff):.3f} ({eff[0]:.3f}–{eff[-1]:.3f}) | {optimum['nees']:.2f} | "
      f"{per_trial:.2f} s, {cost:.3f} s ({100 * cost / per_trial:.1f} %) |")
PY
