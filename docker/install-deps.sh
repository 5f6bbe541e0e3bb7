#!/usr/bin/env bash
# Installs the Debian 12 packages textond builds and tests with; idempotent (does nothing when all
# are present). Used by the README commands, CI and (later) the Dockerfile.
set -euo pipefail

packages=(
    build-essential cmake pkg-config git
    libfftw3-dev libopenimageio-dev openimageio-tools nlohmann-json3-dev libspdlog-dev
    libcpp-httplib-dev libssl-dev libosmesa6-dev libegl-dev libegl-mesa0 libgl1-mesa-dri
    googletest libgtest-dev
    # tests: the API schema test (Debian's python, not whatever python3 is first on PATH), load
    python3 python3-yaml python3-jsonschema wrk curl
)

missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0

echo "install-deps: installing ${missing[*]}" >&2
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
