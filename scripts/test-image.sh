#!/usr/bin/env bash
# scripts/test-image.sh prepare | build IMAGE | remove IMAGE
#
# The podman image of this build that the deployment tests run (tests/integration/test_deployments.cpp,
# test_multihost.cpp; scripts/test sets SWARMLOC_TEST_PODMAN_IMAGE to it). It is
# deploy/k8s/Containerfile.host-binary around the host build, not deploy/container/Containerfile,
# which compiles everything again inside the image (~10-16 min on 2 cores).
#   prepare        needs no build: the registry-free Debian base (deploy/container/make-base.sh, ~1-4 min,
#                  mostly download; kept as a cache when it exists) and the Containerfile's runtime layer
#                  (apt-get install of the shared libraries, ~1 min), built once around a placeholder so
#                  that `build` finds it in podman's layer cache. scripts/test runs it in the background
#                  while it compiles.
#   build IMAGE    the image around build/orchestrator/swarmloc (stripped) and scenarios/: seconds after
#                  `prepare`.
#   remove IMAGE   removes IMAGE and the placeholder image (the base stays, as a cache).
set -euo pipefail
cd "$(dirname "$0")/.."
base=localhost/swarmloc-base:bookworm
prep=localhost/swarmloc-test-prep:latest
containerfile=deploy/k8s/Containerfile.host-binary
# This host: chroot isolation and modest ulimits (deploy/container/README.md).
build_flags=(--layers --isolation chroot --ulimit nofile=1024:1024 --ulimit nproc=1024:1024
             --build-arg "BASE_IMAGE=$base" -f "$containerfile")

context=$(mktemp -d /tmp/swarmloc-image-context.XXXXXX)
trap 'rm -rf "$context"' EXIT

case "${1:-}" in
  prepare)
    if podman image exists "$base"; then
      echo "test-image: base $base exists (kept from an earlier run)"
    else
      deploy/container/make-base.sh "$base"
    fi
    : >"$context/swarmloc"
    mkdir "$context/scenarios"
    podman build "${build_flags[@]}" -t "$prep" "$context" >/dev/null
    echo "test-image: runtime layer cached"
    ;;
  build)
    image=${2:?usage: $0 build IMAGE}
    strip -o "$context/swarmloc" build/orchestrator/swarmloc
    cp -r scenarios "$context/scenarios"
    podman build "${build_flags[@]}" -t "$image" "$context" >/dev/null
    podman run --rm --network none --ulimit nofile=1024:1024 --ulimit nproc=1024:1024 "$image" --help >/dev/null
    echo "test-image: $image ($(podman image inspect --format '{{.Size}}' "$image") bytes)"
    ;;
  remove)
    image=${2:?usage: $0 remove IMAGE}
    podman rmi -f "$image" "$prep" >/dev/null 2>&1 || true
    podman image prune -f >/dev/null 2>&1 || true
    ;;
  *)
    echo "usage: $0 prepare | build IMAGE | remove IMAGE" >&2
    exit 2
    ;;
esac
