#!/usr/bin/env bash
# Build the base image where no container registry is reachable:
# a minimal Debian bookworm root made with debootstrap from Debian's packages,
# with python3 and python3-venv, imported with `docker import`.
# Idempotent: an existing image with the tag is reused (pass --rebuild to force).
#
#   docker/build-base.sh [--rebuild]
#   SWARMACTORS_BASE=tag        image tag to build (default swarmactors-base:bookworm)
#   DEBIAN_MIRROR=URL           Debian mirror (default: the first one this host's apt uses)
set -euo pipefail

tag="${SWARMACTORS_BASE:-swarmactors-base:bookworm}"
if [[ "${1:-}" != "--rebuild" ]] && docker image inspect "$tag" >/dev/null 2>&1; then
    echo "base image $tag exists; reusing it"
    exit 0
fi

if ! command -v debootstrap >/dev/null 2>&1; then
    if [[ $(id -u) -eq 0 ]] && command -v apt-get >/dev/null 2>&1; then
        apt-get update -qq && apt-get install -y -qq debootstrap >/dev/null
    else
        echo "error: debootstrap is not installed (apt-get install debootstrap, as root)" >&2
        exit 2
    fi
fi

mirror="${DEBIAN_MIRROR:-}"
if [[ -z "$mirror" ]]; then
    # the host's own apt configuration: deb822 .sources files first, then sources.list
    mirror=$(awk '/^URIs:/ {print $2; exit}' /etc/apt/sources.list.d/*.sources 2>/dev/null || true)
    [[ -n "$mirror" ]] || mirror=$(awk '$1 == "deb" {print $2; exit}' /etc/apt/sources.list 2>/dev/null || true)
fi
if [[ -z "$mirror" ]]; then
    echo "error: no Debian mirror found in /etc/apt; set DEBIAN_MIRROR" >&2
    exit 2
fi

root=$(mktemp -d /tmp/swarmactors-rootfs.XXXXXX)
trap 'rm -rf "$root"' EXIT
echo "debootstrap bookworm from $mirror into $root"
debootstrap --variant=minbase --include=python3,python3-venv,ca-certificates bookworm "$root" "$mirror" >/dev/null
# slim the root: package lists, caches, documentation
rm -rf "$root"/var/lib/apt/lists/* "$root"/var/cache/apt/* "$root"/usr/share/doc/* "$root"/usr/share/man/*
tar -C "$root" -c . | docker import \
    --change 'ENV LANG=C.UTF-8' \
    --change 'CMD ["/bin/bash"]' \
    - "$tag" >/dev/null
echo "built base image $tag"
