#!/usr/bin/env bash
# The images the compose and kube play tests run, built by podman (set-up: podman_setup.sh):
#   localhost/textond:local                        docker/Dockerfile, as container_test.sh builds
#                                                   it (same build arguments, so one build serves all)
#   localhost/textond-build:local                  its build stage (the next build's cache)
#   localhost/textond-standin/redis:7.0-bookworm   stand-ins for the official images, which no
#   localhost/textond-standin/nginx:1.22-bookworm  registry serves here (tests/deploy/standins/)
# A proxy's CA for the build's downloads: BUILD_CA, else NODE_EXTRA_CA_CERTS (build secret).
#   tests/deploy/build_images.sh HOST_TEXTOND
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
here=$root/tests/deploy
podman build --quiet --network host --pull=never -f "$here/standins/redis.Containerfile" \
    -t localhost/textond-standin/redis:7.0-bookworm "$here/standins" >/dev/null
podman build --quiet --network host --pull=never -f "$here/standins/nginx.Containerfile" \
    -t localhost/textond-standin/nginx:1.22-bookworm "$here/standins" >/dev/null
commit=$("$1" --version | sed -nE 's|^build: textond/[^+]*\+([^ ]*) .*|\1|p')
secret=()
ca=${BUILD_CA:-${NODE_EXTRA_CA_CERTS:-}}
[ -n "$ca" ] && [ -s "$ca" ] && secret=(--secret "id=build_ca,src=$ca")
# The host build's compiler cache, lent to the image's build (its compiles of the same sources
# with the same compiler are lookups, not a second build of textond): /ccache in docker/Dockerfile.
cache=()
if command -v ccache >/dev/null; then
    ccache_dir=$(ccache --get-config cache_dir)
    mkdir -p "$ccache_dir"
    cache=(--volume "$ccache_dir:/ccache")
fi
# The build stage is tagged too, so that what a rebuild replaces can be told from what the next
# build starts from: a change of the sources left about 2.5 GB of untagged images a run.
tags=(localhost/textond-build:local localhost/textond:local)
old=()
for tag in "${tags[@]}"; do old+=("$(podman image inspect -f '{{.Id}}' "$tag" 2>/dev/null || true)"); done
for target in build runtime; do
    tag=${tags[0]}
    [ "$target" = runtime ] && tag=${tags[1]}
    podman build --quiet --network host --pull=never --format docker "${secret[@]}" "${cache[@]}" \
        --build-arg "TEXTOND_COMMIT=$commit" -f "$root/docker/Dockerfile" --target "$target" \
        -t "$tag" "$root" >/dev/null
done
# The images those tags named before, if the build replaced them: removed with the layers only
# they used (one a container still runs is kept).
for id in "${old[@]}"; do
    [ -n "$id" ] || continue
    [ "$(podman image inspect -f '{{len .RepoTags}}' "$id" 2>/dev/null || echo 1)" = 0 ] &&
        podman rmi "$id" >/dev/null 2>&1 || true
done
