#!/usr/bin/env bash
# Build the project image swarmactors:latest.
#   docker/build-image.sh            base = swarmactors-base:bookworm, built by build-base.sh if missing
#   BASE=python:3.11-slim docker/build-image.sh    with a registry
#   IMAGE=tag                        image tag (default swarmactors:latest)
#   IMAGE_UID=1000 IMAGE_GID=1000    the user the image runs as (compose can run it as another: SWARMACTORS_UID)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(dirname "$here")
base="${BASE:-${SWARMACTORS_BASE:-swarmactors-base:bookworm}}"
image="${IMAGE:-swarmactors:latest}"
python="${PYTHON:-python3}"
uid="${IMAGE_UID:-1000}"
gid="${IMAGE_GID:-1000}"

# The image is labelled with a digest of everything that goes into it; an
# image with the same digest is reused (set REBUILD=1 to force a build).
src_hash=$(cd "$repo" && find swarmactors world transport protocols -name '*.py' -print0 | sort -z \
    | xargs -0 cat pyproject.toml constraints.txt docker/Dockerfile | sha256sum | cut -c1-16)
src_hash="$src_hash-$(printf '%s' "$base:$uid:$gid" | sha256sum | cut -c1-8)"
have=$(docker image inspect -f '{{ index .Config.Labels "swarmactors.src" }}' "$image" 2>/dev/null || true)
if [[ "$have" == "$src_hash" && -z "${REBUILD:-}" ]]; then
    echo "image $image is up to date ($src_hash); reusing it"
    exit 0
fi
if [[ -z "${BASE:-}" ]]; then
    "$here/build-base.sh"
fi
# Wheels for the project and its pinned dependencies, for the image's Python (3.11, glibc). The dependencies
# (docker/wheels/deps, the same bytes from one build to the next) and the project (docker/wheels/project) go
# into separate layers, so a change of the project's code reuses the cached layer of its dependencies.
rm -rf "$here/wheels"
"$python" -m pip wheel --quiet -w "$here/wheels/deps" -c "$repo/constraints.txt" "$repo"
mkdir -p "$here/wheels/project"
mv "$here"/wheels/deps/swarmactors-*.whl "$here/wheels/project/"
docker build --quiet -f "$here/Dockerfile" --build-arg "BASE=$base" --build-arg "UID=$uid" --build-arg "GID=$gid" \
    --label "swarmactors.src=$src_hash" \
    -t "$image" "$repo" >/dev/null
echo "built $image from $base"
