#!/usr/bin/env bash
# Every range estimator x {default, 30 % loss + ±200 ppm drift + ±1 s offsets, ea2 moving}: MC RMSE over
# TRIALS trials (√ of the mean final squared error), the bound of the estimator's data and the mean final
# NEES, as the markdown table of docs/validation.md. Usage: bench/validation-table.sh [TRIALS] (default 20).
set -euo pipefail
cd "$(dirname "$0")/.."
trials=${1:-20}
swarmloc=${SWARMLOC:-build/orchestrator/swarmloc}  # a copy keeps a long table safe from rebuilds
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
skew=(--set network.loss=0.3 --set clock.drift_ppm=200 --set clock.offset_max_s=1 --set run.sim_clock=agents)
cell() {  # scenario algorithm extra-args… → "rmse, ratio, NEES" or the reason it does not run
  local scenario=$1 algorithm=$2
  shift 2
  local out="$work/$algorithm.$RANDOM"
  if ! "$swarmloc" sim "$scenario" -q --trials "$trials" --set algorithm.name="$algorithm" "$@" --out "$out" \
    >"$work/log" 2>&1; then
    echo "does not run: $(grep -m1 error "$work/log" | sed 's/.*error: //; s/|/\\|/g' | cut -c1-70)"
    return
  fi
  python3 - "$out" <<'PY'
import csv, json, sys
out = sys.argv[1]
mc = json.load(open(out + "/summary.json"))["monte_carlo"]
rows = list(csv.DictReader(open(out + "/montecarlo.csv")))
bound = json.load(open(out + "/summary.json"))["bound"]
print(f"{mc['mc_rmse_m']:.4f} m, {mc['ratio']:.2f}× {bound['kind'].replace('crlb_static_accumulated', 'CRLB').replace('pcrb', 'PCRB')}, NEES {float(rows[-1]['nees_mean']):.1f}")
PY
}
echo "| estimator | default | 30 % loss, ±200 ppm, ±1 s | ea2 (moving) |"
echo "|---|---|---|---|"
for algorithm in dml dml_track ieif iekf ekf lbekf lbekf_vr lbekf_i dgbb local_bb; do
  if [[ $algorithm == ekf || $algorithm == lbekf* ]]; then  # the fusion centre steps with the world
    skewed=$(cell scenarios/default.yaml "$algorithm" --set network.loss=0.3)
    skewed="$skewed (loss only)"
  else
    skewed=$(cell scenarios/default.yaml "$algorithm" "${skew[@]}")
  fi
  echo "| \`$algorithm\` | $(cell scenarios/default.yaml "$algorithm") | $skewed | $(cell scenarios/ea2.yaml "$algorithm") |"
done
