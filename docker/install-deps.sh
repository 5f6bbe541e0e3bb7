#!/usr/bin/env bash
# Installs the Debian 12 packages textond builds and tests with; idempotent (does nothing when all
# are present). Used by the README commands, CI and (later) the Dockerfile.
set -euo pipefail

packages=(
    build-essential cmake pkg-config git
    libfftw3-dev libopenimageio-dev openimageio-tools nlohmann-json3-dev libspdlog-dev
    libcpp-httplib-dev libssl-dev libosmesa6-dev libegl-dev libegl-mesa0 libgl1-mesa-dri
    googletest libgtest-dev
    # tests: the API schema test (Debian's python, not whatever python3 is first on PATH), load,
    # the browser test (Debian's Chromium driven by playwright-core)
    python3 python3-yaml python3-jsonschema wrk curl chromium chromium-driver
)
# Node.js and npm for the page's Leaflet and the browser test: Debian's unless one is installed.
command -v npm >/dev/null || packages+=(nodejs npm)

missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -ne 0 ]; then
    echo "install-deps: installing ${missing[*]}" >&2
    SUDO=""
    [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    export DEBIAN_FRONTEND=noninteractive
    $SUDO apt-get update -qq
    $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# npm packages, from the lock files, only when missing: Leaflet for the page, playwright-core for
# the browser test.
root=$(cd "$(dirname "$0")/.." && pwd)
for dir in server/web tests/web; do
    [ -f "$root/$dir/package-lock.json" ] || continue
    if [ ! -d "$root/$dir/node_modules" ] || [ "$root/$dir/package-lock.json" -nt "$root/$dir/node_modules" ]; then
        echo "install-deps: npm ci in $dir" >&2
        (cd "$root/$dir" && npm ci --no-audit --no-fund --loglevel=error >/dev/null)
        touch "$root/$dir/node_modules"
    fi
done
