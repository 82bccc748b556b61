#!/usr/bin/env bash
# Installs the build tree into a temporary prefix, then configures, builds and runs a project outside
# swarmloc against it with find_package(swarmloc). Usage: check-install.sh BUILD_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake --install "$build" --prefix "$work/prefix" >/dev/null
for binary in swarmloc swarmloc-agent; do
  [[ -x $work/prefix/bin/$binary ]] || { echo "not installed: bin/$binary" >&2; exit 1; }
done
[[ -f $work/prefix/share/swarmloc/scenarios/default.yaml ]] || { echo "scenarios not installed" >&2; exit 1; }
cmake -S "$here/consumer" -B "$work/consumer" -G Ninja -DCMAKE_PREFIX_PATH="$work/prefix" >/dev/null
cmake --build "$work/consumer" >/dev/null
"$work/consumer/consumer"
