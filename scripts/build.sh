#!/usr/bin/env bash
# scripts/build.sh [--run-only] [CMAKE_ARGS...]
#
# Configures and builds swarmloc into build/ (RelWithDebInfo). Extra arguments go to cmake (they come
# last, so e.g. -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g -DNDEBUG" restores full debug information).
# -g1 (line tables): profiles and backtraces keep file:line, and the heaviest files compile ~26 % faster
# than with -g (multipath_bp.cpp: 25 s against 34 s of CPU).
#
# --run-only (scripts/run-default): build only what running needs, the `swarmloc` and `swarmloc-agent`
# targets. A new build/ is configured without tests, benchmarks and research/ (their packages are
# `scripts/install-deps.sh --test`'s); a build/ that is already configured keeps its options (the test
# configuration is a superset), so scripts/test and scripts/run-default share build/ without
# reconfiguring it back and forth. Without --run-only everything is built.
set -euo pipefail
cd "$(dirname "$0")/.."
run_only=0
if [ "${1:-}" = "--run-only" ]; then run_only=1; shift; fi
configure=(cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo
           -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG")
if ((run_only)); then
  if [ ! -f build/CMakeCache.txt ]; then
    "${configure[@]}" -DSWARMLOC_BUILD_TESTS=OFF -DSWARMLOC_BUILD_BENCH=OFF -DSWARMLOC_BUILD_RESEARCH=OFF \
      "$@" >/dev/null
  elif [ $# -gt 0 ]; then
    cmake -S . -B build "$@" >/dev/null
  fi
  cmake --build build -j"$(nproc)" --target swarmloc swarmloc-agent
else
  "${configure[@]}" -DSWARMLOC_BUILD_TESTS=ON -DSWARMLOC_BUILD_BENCH=ON -DSWARMLOC_BUILD_RESEARCH=ON \
    "$@" >/dev/null
  cmake --build build -j"$(nproc)"
fi
