#!/usr/bin/env bash
# The Dockerfile's two stages without a Docker engine (none runs on our build machines): a clean
# Debian 12 minbase made by debootstrap stands in for debian:bookworm-slim. The build stage runs
# the same commands as docker/Dockerfile on a copy of the committed tree; the runtime stage gets
# only `install-deps.sh --runtime`, the binary and the page, and runs `textond serve` as uid
# 10001; the HEALTHCHECK command and a tile request must succeed against it.
#   docker/chroot_build_test.sh [WORKDIR]     (root; needs debootstrap; about 10-20 minutes)
# Not part of `make test` (time, root, network); its last result is in deploy/README.md "Run at scale".
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
work=${1:-$root/build/chroot}
mirror=${MIRROR:-http://deb.debian.org/debian}
[ "$(id -u)" -eq 0 ] || { echo "chroot_build_test: needs root (debootstrap, chroot)" >&2; exit 1; }
command -v debootstrap >/dev/null || apt-get install -y -qq debootstrap >/dev/null

step() { printf '\n== %s (%ds)\n' "$1" "$SECONDS"; }
mounted=()
cleanup() { for m in "${mounted[@]}"; do umount -l "$m" 2>/dev/null || true; done; }
trap cleanup EXIT
bootstrap() {
    local dir=$1
    if [ ! -x "$dir/bin/bash" ]; then
        rm -rf "$dir"
        debootstrap --variant=minbase bookworm "$dir" "$mirror" >"$work/$(basename "$dir").log"
    fi
    mount -t proc proc "$dir/proc" && mounted+=("$dir/proc")
    cp /etc/resolv.conf "$dir/etc/resolv.conf"
}
mkdir -p "$work"

step "build stage: debootstrap"
build=$work/build-stage
bootstrap "$build"
rm -rf "$build/src" && mkdir -p "$build/src"
git -C "$root" archive HEAD | tar -x -C "$build/src"
commit=$(git -C "$root" rev-parse --short=12 HEAD)
# Behind a TLS-intercepting proxy (as on our build machines) npm needs the host's extra CAs; a
# docker build on an open network does not.
extra_ca=""
if ls /usr/local/share/ca-certificates/*.crt >/dev/null 2>&1; then
    cat /usr/local/share/ca-certificates/*.crt >"$build/tmp/host-extra-ca.crt"
    extra_ca="export NODE_EXTRA_CA_CERTS=/tmp/host-extra-ca.crt"
fi
step "build stage: install-deps.sh --build, cmake (as the Dockerfile)"
chroot "$build" /bin/bash -euc "
    $extra_ca
    cd /src
    apt-get update -qq && bash docker/install-deps.sh --build
    cmake --preset release -DTEXTOND_BUILD_TESTS=OFF -DTEXTOND_COMMIT=$commit >/dev/null
    cmake --build build/release -j \$(nproc) --target textond textond_web >/dev/null
    strip build/release/textond"

step "runtime stage: debootstrap, install-deps.sh --runtime"
run=$work/runtime-stage
bootstrap "$run"
cp "$root/docker/install-deps.sh" "$run/tmp/install-deps.sh"
chroot "$run" /bin/bash -euc "apt-get update -qq && bash /tmp/install-deps.sh --runtime
    id textond >/dev/null 2>&1 || useradd --system --uid 10001 --home-dir /var/lib/textond --create-home textond"
cp "$build/src/build/release/textond" "$run/usr/local/bin/textond"
rm -rf "$run/usr/local/share/textond" && mkdir -p "$run/usr/local/share/textond"
cp -r "$build/src/build/release/web" "$run/usr/local/share/textond/web"
echo "runtime stage: $(du -sh --exclude=proc "$run" | cut -f1), textond $(du -h "$run/usr/local/bin/textond" | cut -f1)"

step "runtime stage: textond serve as uid 10001 (the image's ENV and CMD)"
port=${PORT:-18480}
chroot --userspec=10001:10001 "$run" /usr/bin/env -i HOME=/var/lib/textond TEXTOND_HOST=127.0.0.1 \
    TEXTOND_PORT=$port TEXTOND_DATA=/var/lib/textond TEXTOND_WEB_DIR=/usr/local/share/textond/web \
    /usr/local/bin/textond serve >"$work/serve.log" 2>&1 &
pid=$!
for _ in $(seq 100); do grep -q "listening on" "$work/serve.log" && break; sleep 0.1; done
chroot --userspec=10001:10001 "$run" /usr/local/bin/textond probe "http://127.0.0.1:$port/healthz"
echo "HEALTHCHECK (textond probe) inside the runtime stage: ok"
exemplar=$root/../shared/data/exemplars/etr_sand01.png
[ -f "$exemplar" ] || exemplar=$root/shared/data/exemplars/etr_sand01.png
id=$(curl -sf --data-binary @"$exemplar" "http://127.0.0.1:$port/v1/textons?size=32" |
     sed -n 's/.*"id": "\([0-9a-f]\{64\}\)".*/\1/p')
code=$(curl -s -o /dev/null -w '%{http_code}' "http://127.0.0.1:$port/v1/textons/$id/tiles/0/0/0.png")
page=$(curl -s -o /dev/null -w '%{http_code}' "http://127.0.0.1:$port/static/leaflet/leaflet.js")
kill -TERM $pid && wait $pid
echo "upload -> $id, tile -> $code, page's Leaflet -> $page, SIGTERM -> exit 0"
[ "$code" = 200 ] && [ "$page" = 200 ]
ls -ln "$run/var/lib/textond/textons" | tail -1
step "ok"
