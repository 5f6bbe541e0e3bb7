#!/usr/bin/env bash
# Installs the Debian 12 packages textond needs; idempotent (does nothing when all are present).
# One list for the README commands, CI and the Dockerfile:
#   install-deps.sh            build and test (the README's `make test`, CI)
#   install-deps.sh --build    build only (the Dockerfile's build stage)
#   install-deps.sh --runtime  run only, no compilers or headers (the Dockerfile's final stage)
set -euo pipefail

mode=${1:-all}
case "$mode" in all | --build | --runtime) ;; *)
    echo "usage: $0 [--build | --runtime]" >&2
    exit 2
    ;;
esac

build=(
    build-essential cmake pkg-config git ca-certificates ccache
    libfftw3-dev libopenimageio-dev nlohmann-json3-dev libspdlog-dev libcpp-httplib-dev
    libssl-dev libhiredis-dev libosmesa6-dev libegl-dev libwebp-dev libavif-dev libsqlite3-dev
)
# What the binary links and loads (dlopen: OSMesa, EGL with Mesa's and, under the NVIDIA
# runtime, the driver's vendor library). tests/deploy/deploy_test.py checks this list against
# the binary's NEEDED libraries.
runtime=(
    libopenimageio2.4 libfftw3-single3 libspdlog1.10 libfmt9 libcpp-httplib0.11 libssl3
    libhiredis0.14 libgomp1 libosmesa6 libegl1 libegl-mesa0 libgl1-mesa-dri libwebp7 libavif15 libsqlite3-0
)
tests=(
    openimageio-tools googletest libgtest-dev
    # the style checks (tests/style/format_check.sh, tidy_check.sh)
    clang-format clang-tidy-22
    # the deflate benchmark (tests/bench: zlib against libdeflate on tile bytes)
    zlib1g-dev libdeflate-dev
    # the API schema and deployment tests (Debian's python, not whatever python3 is first on
    # PATH), load (wrk, nginx), the browser test (Debian's Chromium driven by playwright-core),
    # the shared store (redis-server), compose files validated without an engine
    # (docker-compose), manifests against the Kubernetes API schema (python3-kubernetes), the
    # engine kit's HLSL run under OSMesa (glslang-tools, spirv-cross)
    python3 python3-yaml python3-jsonschema python3-kubernetes wrk curl nginx-light redis-server
    chromium chromium-driver docker-compose glslang-tools spirv-cross
)

case "$mode" in
all) packages=("${build[@]}" "${runtime[@]}" "${tests[@]}") ;;
--build) packages=("${build[@]}") ;;
--runtime) packages=("${runtime[@]}") ;;
esac
# Node.js and npm for the page's Leaflet (and the browser test): Debian's unless one is installed.
if [ "$mode" != --runtime ] && ! command -v npm >/dev/null; then packages+=(nodejs npm); fi
# kubectl renders the kustomize manifests in the tests; some machines have a newer one already.
if [ "$mode" = all ] && ! command -v kubectl >/dev/null; then packages+=(kubernetes-client); fi

missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# Build packages and installed headers (every -dev package: those the list pulls in, such as
# libbrotli-dev through cpp-httplib, count too) older than the version apt offers: the image's
# build (docker/Dockerfile) gets the newest, and ccache, which hashes every header a compile
# reads, would miss on each file that includes one that differs (an older libssl-dev, then
# libbrotli-dev, here cost the image about 20 compiles of server/ each).
stale_build_packages() {
    [ "$mode" != --runtime ] || return 0
    local dev=()
    mapfile -t dev < <(dpkg-query -W -f '${db:Status-Abbrev} ${Package}\n' 2>/dev/null |
        awk '$1 == "ii" && $2 ~ /-dev$/ { print $2 }')
    LANG=C apt-cache policy "${build[@]}" "${dev[@]}" 2>/dev/null | awk '
        /^[^ ]/ { p = substr($1, 1, length($1) - 1) }
        $1 == "Installed:" { i = $2 }
        $1 == "Candidate:" && i != "(none)" && $2 != "(none)" && $2 != i { print p " " i " " $2 }' |
        while read -r p i c; do if dpkg --compare-versions "$c" gt "$i"; then echo "$p"; fi; done |
        sort -u
}
mapfile -t stale < <(stale_build_packages)
if [ ${#missing[@]} -ne 0 ] || [ ${#stale[@]} -ne 0 ]; then
    SUDO=""
    [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    export DEBIAN_FRONTEND=noninteractive
    $SUDO apt-get update -qq
    mapfile -t stale < <(stale_build_packages)
    echo "install-deps: installing${missing[*]:+ ${missing[*]}}${stale[*]:+ ${missing[*]:+and }newer ${stale[*]}}" >&2
    $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" "${stale[@]}" >/dev/null
fi
[ "$mode" = --runtime ] && exit 0

# npm packages, from the lock files, only when missing: Leaflet for the page, and (for tests)
# playwright-core for the browser test.
root=$(cd "$(dirname "$0")/.." && pwd)
dirs=(server/web)
[ "$mode" = all ] && dirs+=(tests/web)
for dir in "${dirs[@]}"; do
    [ -f "$root/$dir/package-lock.json" ] || continue
    if [ ! -d "$root/$dir/node_modules" ] || [ "$root/$dir/package-lock.json" -nt "$root/$dir/node_modules" ]; then
        echo "install-deps: npm ci in $dir" >&2
        (cd "$root/$dir" && npm ci --no-audit --no-fund --loglevel=error >/dev/null)
        touch "$root/$dir/node_modules"
    fi
done
