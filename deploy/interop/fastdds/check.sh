#!/usr/bin/env bash
# Fast DDS interoperability check: an eProsima Fast DDS 2.9 reader (not Cyclone) subscribes to
# swarmloc's estimate topic during a real `swarmloc run` and must read the same values the
# orchestrator wrote to the run directory's estimates.csv. README.md beside this file explains it.
#
#   deploy/interop/fastdds/check.sh                 # from the repo root; exit 0 = pass
#
# Environment (all optional):
#   SWARMLOC_BIN  swarmloc binary (default build/orchestrator/swarmloc)
#   DOMAIN        DDS domain id (default 61)        AGENTS  agents (default 20)
#   STEPS         world steps (default 100)         MODE    lockstep (default) | free_run
#   OUT           output directory (default: a new mktemp -d; kept)
#   BUILD_DIR     reader build directory (default build-interop-fastdds)
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../../.." && pwd)"
bin="${SWARMLOC_BIN:-$repo/build/orchestrator/swarmloc}"
domain="${DOMAIN:-61}"
agents="${AGENTS:-20}"
steps="${STEPS:-100}"
mode="${MODE:-lockstep}"
build_dir="${BUILD_DIR:-$repo/build-interop-fastdds}"
out="${OUT:-$(mktemp -d /tmp/swarmloc-fastdds-XXXXXX)}"
started=$(date +%s%N)

fail() { echo "FAIL: $*" >&2; exit 1; }

[[ -x "$bin" ]] || fail "no swarmloc binary at $bin (build it: cmake -S . -B build -G Ninja && ninja -C build swarmloc, or set SWARMLOC_BIN)"

# 1. Fast DDS, fastddsgen (brings Java) and CMake/Ninja, from Debian, only if missing.
missing=()
for pkg in libfastrtps-dev libfastcdr-dev fastddsgen cmake ninja-build g++ python3; do
  dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
done
if ((${#missing[@]})); then
  echo "installing ${missing[*]}"
  sudo=""; [[ $(id -u) -eq 0 ]] || sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y --no-install-recommends "${missing[@]}"
fi

# 2. The reader; its types are generated from idl/swarmloc.idl at build time.
cmake -S "$here" -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release >"$out/reader-cmake.log" 2>&1 ||
  fail "reader configure failed; see $out/reader-cmake.log"
ninja -C "$build_dir" -j2 >"$out/reader-build.log" 2>&1 || fail "reader build failed; see $out/reader-build.log"
reader="$build_dir/swarmloc_fastdds_reader"

# 3. Reader first (it announces itself to every agent's discovery port), then the run.
"$reader" --domain "$domain" --agents "$agents" --max-seconds 900 \
  >"$out/fastdds_estimates.csv" 2>"$out/fastdds_reader.log" &
reader_pid=$!
trap 'kill "$reader_pid" 2>/dev/null || true' EXIT
sleep 1
kill -0 "$reader_pid" 2>/dev/null || fail "the reader exited at start; see $out/fastdds_reader.log"

run_started=$(date +%s%N)
run_rc=0
"$bin" run "$repo/scenarios/default.yaml" --out "$out/run" --quiet \
  --set dds.domain_id="$domain" --set world.agents="$agents" --set run.steps="$steps" \
  --set run.mode="$mode" >"$out/run.log" 2>&1 || run_rc=$?
run_ms=$((($(date +%s%N) - run_started) / 1000000))
[[ $run_rc -eq 0 ]] || fail "swarmloc run exited with $run_rc; see $out/run.log"

sleep 0.5  # the last reliable retransmissions
kill -TERM "$reader_pid"
wait "$reader_pid" || fail "the reader exited with an error; see $out/fastdds_reader.log"
trap - EXIT

# 4. Compare.
compare_rc=0
python3 "$here/compare.py" "$out/fastdds_estimates.csv" "$out/run" --mode "$mode" || compare_rc=$?
total_ms=$((($(date +%s%N) - started) / 1000000))
printf 'fastdds interop: %d agents, %d steps, domain %d; swarmloc run %d.%01d s, whole check %d.%01d s; files in %s\n' \
  "$agents" "$steps" "$domain" $((run_ms / 1000)) $((run_ms % 1000 / 100)) $((total_ms / 1000)) $((total_ms % 1000 / 100)) "$out"
exit "$compare_rc"
