#!/usr/bin/env bash
# Plots every agent's estimated trajectory against its groundtruth from a run directory's TUM files
# (trajectories/agent_N.tum and agent_N_truth.tum): scripts/plot-trajectories.sh RUN_DIR OUT.png
set -euo pipefail
run_dir=${1:?usage: plot-trajectories.sh RUN_DIR OUT.png}
out=${2:?usage: plot-trajectories.sh RUN_DIR OUT.png}
command -v gnuplot >/dev/null || { echo "error: gnuplot is missing (scripts/install-deps.sh installs it)" >&2; exit 2; }
shopt -s nullglob
files=("$run_dir"/trajectories/agent_*_truth.tum)
[[ ${#files[@]} -gt 0 ]] || { echo "error: no TUM files in $run_dir/trajectories" >&2; exit 2; }
plots=()
for truth in "${files[@]}"; do
  estimate=${truth%_truth.tum}.tum
  agent=$(basename "${estimate%.tum}")
  plots+=("'$truth' using 2:3 with lines lw 1 lc rgb '#999999' notitle")
  plots+=("'$estimate' using 2:3 with lines lw 1 title '${agent//_/ } estimate'")
done
plots[0]=${plots[0]%notitle}"title 'groundtruth'"
gnuplot <<GP
set terminal pngcairo size 900,900 font ',10'
set output '$out'
set size ratio -1
set xlabel 'x (m)'
set ylabel 'y (m)'
set key outside bottom center horizontal
set title "$(basename "$run_dir"): estimated trajectories (colour) and groundtruth (grey)"
plot $(IFS=,; echo "${plots[*]}")
GP
echo "wrote $out"
