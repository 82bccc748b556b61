#!/usr/bin/env bash
# The "Any start" table of docs/validation.md: seeds 1–20 × TRIALS trials of the default scenario per
# estimator and start; a trial's ratio is its final RMSE over its world's bound, flagged = some agent's
# self-check flags at the end. Usage: bench/any-start-table.sh ALGORITHM START [TRIALS] [extra --set…]
# (START: noisy_truth|uniform; TRIALS default 10). Prints one markdown row, then the trials above 2×.
set -euo pipefail
cd "$(dirname "$0")/.."
algorithm=$1 start=$2 trials=${3:-10}
shift $(($# < 3 ? $# : 3))
swarmloc=${SWARMLOC:-build/orchestrator/swarmloc}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for seed in $(seq 1 20); do
  "$swarmloc" sim scenarios/default.yaml -q --trials "$trials" --set algorithm.name="$algorithm" \
    --set seed="$seed" --set world.initial_guess="$start" "$@" --out "$work/$seed" >/dev/null 2>&1
done
python3 - "$work" "$algorithm" "$start" <<'PY'
import csv, json, math, sys
work, algorithm, start = sys.argv[1:]
rows = []
for seed in range(1, 21):
    bound = json.load(open(f"{work}/{seed}/summary.json"))["bound"]["rmse_m"]
    for t in csv.DictReader(open(f"{work}/{seed}/trials.csv")):
        rows.append((seed, int(t["trial"]), float(t["final_rmse_m"]), bound, int(t["flagged_agents"]) > 0))
n = len(rows)
ok = [r for r in rows if r[2] <= 2 * r[3]]
bad = [r for r in rows if r[2] > 2 * r[3]]
wrong = [r for r in rows if r[2] > 10 * r[3]]
# Pooled MC RMSE over the pooled bound: √(Σ rmse² / Σ bound²) over all trials.
pooled = math.sqrt(sum(r[2] ** 2 for r in rows) / sum(r[3] ** 2 for r in rows))
print(f"| {algorithm}, {start} | {n} | {len(ok)} ({100 * len(ok) / n:.1f} %) | "
      f"{sum(r[4] for r in bad)} of {len(bad)} | {len(wrong)} ({sum(r[4] for r in wrong)} flagged) | "
      f"{sum(r[4] for r in ok)} | {pooled:.3f} |")
for seed, trial, rmse, bound, flagged in bad:
    print(f"  seed {seed} trial {trial}: {rmse:.4f} m, {rmse / bound:.2f}x, flagged {flagged}")
PY
