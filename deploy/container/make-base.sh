#!/usr/bin/env bash
# make-base.sh [IMAGE_NAME] [MIRROR]
#
# Builds the Debian bookworm base image the Containerfile starts from, without any container
# registry: debootstrap a minbase rootfs and `podman import` it (docs/measurements/feasibility.md §2).
#   IMAGE_NAME  default localhost/swarmloc-base:bookworm (the Containerfile's default BASE_IMAGE)
#   MIRROR      default: the URIs: line of /etc/apt/sources.list.d/debian.sources, else deb.debian.org
# Needs root, debootstrap and podman (buildah users: `buildah import` is not a command; use
# `tar -C ROOTFS -c . | podman import -` or `buildah from scratch` + copy). Takes about a minute.
set -euo pipefail

IMAGE=${1:-localhost/swarmloc-base:bookworm}
MIRROR=${2:-$(sed -n 's/^URIs: *//p' /etc/apt/sources.list.d/debian.sources 2>/dev/null | head -1)}
MIRROR=${MIRROR:-http://deb.debian.org/debian}

[ "$(id -u)" -eq 0 ] || { echo "make-base: needs root (debootstrap)" >&2; exit 2; }
command -v debootstrap >/dev/null || { echo "make-base: apt-get install debootstrap" >&2; exit 2; }
command -v podman >/dev/null || { echo "make-base: apt-get install podman" >&2; exit 2; }

ROOTFS=$(mktemp -d /var/tmp/swarmloc-rootfs.XXXXXX)
trap 'rm -rf "$ROOTFS"' EXIT

echo "make-base: debootstrap bookworm from $MIRROR"
debootstrap --variant=minbase bookworm "$ROOTFS" "$MIRROR" >/dev/null
# apt inside the image: the same mirror; no caches or lists in the layer.
echo "deb $MIRROR bookworm main" >"$ROOTFS/etc/apt/sources.list"
rm -rf "$ROOTFS"/var/lib/apt/lists/* "$ROOTFS"/var/cache/apt/archives/*.deb
tar -C "$ROOTFS" -c . | podman import - "$IMAGE" >/dev/null
echo "make-base: $IMAGE"
podman image ls "$IMAGE"
